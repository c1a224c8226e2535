"""RGB frames of the cell: the LWR's camera beside a fixed overview of the table."""

from __future__ import annotations

import mujoco
import numpy as np

from cell.robots.names import CAMERA

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
        self._renderer = mujoco.Renderer(model, height_px, width_px)
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
