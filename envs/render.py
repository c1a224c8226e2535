"""How the envs show the cell: RGB frames (``rgb_array``: the LWR's camera beside a fixed
overview of the table) or MuJoCo's interactive viewer in a window (``human``)."""

from __future__ import annotations

import mujoco
import numpy as np

from cell.errors import InputError
from cell.robots.names import CAMERA
from cell.sim.liveview import has_display
from cell.sim.picture import MAX_PX, MIN_PX

#: The envs' render modes.
RENDER_MODES = ("rgb_array", "human")


def check_render(render_mode: str | None, width_px: int, height_px: int) -> None:
    """Refuse a render mode the envs do not have, ``human`` where no window can open, and a
    view's size outside :data:`~cell.sim.picture.MIN_PX`..:data:`~cell.sim.picture.MAX_PX`.

    Example:
        >>> check_render("rgb_array", 8, 240)
        Traceback (most recent call last):
        cell.errors.InputError: width: must be an integer in 16..4096 px, got 8
    """
    if render_mode not in (None, *RENDER_MODES):
        raise InputError(None, "render_mode", f"must be None, {' or '.join(RENDER_MODES)}, "
                         f"got {render_mode!r}")
    if render_mode == "human" and not has_display():
        raise InputError(None, "render_mode", "human opens MuJoCo's viewer in a window, which "
                         "needs a display (DISPLAY or WAYLAND_DISPLAY); there is none here: "
                         "use rgb_array")
    for field, pixels in (("width", width_px), ("height", height_px)):
        if isinstance(pixels, bool) or not isinstance(pixels, int) or not (
                MIN_PX <= pixels <= MAX_PX):
            raise InputError(None, field, f"must be an integer in {MIN_PX}..{MAX_PX} px, got "
                             f"{pixels!r}")

#: The overview looks at the meat from this far (m), azimuth and elevation (degrees).
_OVERVIEW_DISTANCE_M = 1.4
_OVERVIEW_AZIMUTH_DEG = 150.0
_OVERVIEW_ELEVATION_DEG = -35.0


class CellRenderer:
    """Renders the camera arm's view and a fixed overview side by side.

    Args:
        model: the scene's model.
        look_at_m: the overview's centre (world frame), e.g. the meat's middle.
        width_px, height_px: size of each of the two views.

    Example:
        >>> from cell.sim.episode import Episode
        >>> from cell.sim.scenario import Scenario
        >>> from cell.tissue.shape import MuscleShape
        >>> episode = Episode(Scenario(tissue=MuscleShape(cell_size_m=0.05)))  # arms ready
        >>> renderer = CellRenderer(episode.sim.model, np.array([0.0, 0.0, 0.65]))
        >>> renderer.render(episode.sim.data).shape
        (240, 640, 3)
        >>> renderer.close()
    """

    def __init__(self, model: mujoco.MjModel, look_at_m: np.ndarray, width_px: int = 320,
                 height_px: int = 240) -> None:
        settings = model.vis.global_
        kept = settings.offwidth, settings.offheight
        # The offscreen buffer is sized from the model when the renderer is made.
        settings.offwidth, settings.offheight = max(width_px, kept[0]), max(height_px, kept[1])
        try:
            self._renderer = mujoco.Renderer(model, height_px, width_px)
        finally:
            settings.offwidth, settings.offheight = kept
        self._camera = model.camera(CAMERA).id
        self._overview = mujoco.MjvCamera()
        self._overview.lookat[:] = look_at_m
        self._overview.distance = _OVERVIEW_DISTANCE_M
        self._overview.azimuth = _OVERVIEW_AZIMUTH_DEG
        self._overview.elevation = _OVERVIEW_ELEVATION_DEG

    def render(self, data: mujoco.MjData) -> np.ndarray:
        """(H, 2 W, 3) uint8: the LWR camera's image, then the overview."""
        views = []
        for camera in (self._camera, self._overview):
            self._renderer.update_scene(data, camera)
            views.append(self._renderer.render())
        return np.hstack(views)

    def close(self) -> None:
        """Free the GL context."""
        self._renderer.close()


class CellWindow:
    """The cell in MuJoCo's interactive viewer (``human`` rendering): a window that follows
    the simulation at each :meth:`render`. Needs a display (:func:`check_render`).

    Args:
        model, data: the scene's model and the data the episode steps.

    Example:
        >>> CellWindow.__name__  # needs a display: see docs/envs.md
        'CellWindow'
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        import mujoco.viewer

        self._viewer = mujoco.viewer.launch_passive(model, data)

    def render(self, data: mujoco.MjData) -> None:
        """Show the present state of ``data`` (the one the window was opened on)."""
        self._viewer.sync()

    def close(self) -> None:
        """Close the window."""
        self._viewer.close()
