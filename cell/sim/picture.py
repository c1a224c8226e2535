"""A picture of the cell: the assembled model drawn headless (``MUJOCO_GL=egl``) from a free
camera or one of the model's cameras, encoded as PNG.
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import mujoco
import numpy as np
from PIL import Image

from cell.errors import InputError


@dataclass(frozen=True)
class View:
    """A free camera that orbits a point.

    Attributes:
        lookat_m: the point looked at, world frame, m.
        distance_m: from the camera to that point, m.
        azimuth_deg: about the vertical axis, from the world x axis, degrees.
        elevation_deg: above (negative) or below (positive) the horizontal, degrees.
        fovy_deg: vertical field of view, degrees.

    Example:
        >>> View().distance_m > 0
        True
    """

    lookat_m: tuple[float, float, float] = (0.1, 0.05, 0.5)
    distance_m: float = 2.9
    azimuth_deg: float = 140.0
    elevation_deg: float = -26.0
    fovy_deg: float = 45.0


#: Smallest and largest picture side, px.
MIN_PX, MAX_PX = 16, 4096
#: The front-page view: both arms, the camera arm, the fixture and the meat.
CELL_VIEW = View()


def check_size(width: int, height: int) -> None:
    """Refuse a picture side outside :data:`MIN_PX`..:data:`MAX_PX`, naming ``--width`` or
    ``--height``.

    Example:
        >>> check_size(0, 720)
        Traceback (most recent call last):
        cell.errors.InputError: --width: must be in 16..4096 px, got 0
    """
    for option, pixels in (("--width", width), ("--height", height)):
        if not MIN_PX <= pixels <= MAX_PX:
            raise InputError(None, option, f"must be in {MIN_PX}..{MAX_PX} px, got {pixels}")


def render_rgb(model: mujoco.MjModel, data: mujoco.MjData, width: int, height: int,
               camera: str | None = None, view: View = CELL_VIEW) -> np.ndarray:
    """The scene as an (height, width, 3) uint8 image, from the model camera ``camera`` or,
    when None, from the free camera ``view``.

    Raises:
        InputError: a side outside :data:`MIN_PX`..:data:`MAX_PX`, or a camera the model
            does not have (naming ``--width``, ``--height`` or ``--camera``).
    """
    check_size(width, height)
    if camera is not None and mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera) < 0:
        names = [model.camera(i).name for i in range(model.ncam)]
        raise InputError(None, "--camera", f"no camera {camera!r} (the model has: "
                         f"{', '.join(names) or 'none'}; leave it out for the free view)")
    free = mujoco.MjvCamera()
    free.type = mujoco.mjtCamera.mjCAMERA_FREE
    free.lookat[:] = view.lookat_m
    free.distance, free.azimuth, free.elevation = (view.distance_m, view.azimuth_deg,
                                                   view.elevation_deg)
    settings = model.vis.global_
    kept = settings.fovy, settings.offwidth, settings.offheight
    # The offscreen buffer is sized from the model when the renderer is made.
    settings.fovy = view.fovy_deg
    settings.offwidth, settings.offheight = max(width, kept[1]), max(height, kept[2])
    try:
        with mujoco.Renderer(model, height, width) as renderer:
            renderer.update_scene(data, camera if camera is not None else free)
            return renderer.render().copy()
    finally:
        settings.fovy, settings.offwidth, settings.offheight = kept


def png_bytes(rgb: np.ndarray) -> bytes:
    """An (H, W, 3) uint8 image as PNG bytes, encoded by Pillow.

    Example:
        >>> png_bytes(np.zeros((2, 3, 3), np.uint8))[:8]
        b'\\x89PNG\\r\\n\\x1a\\n'
    """
    buffer = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgb, dtype=np.uint8)).save(
        buffer, format="PNG", optimize=True)
    return buffer.getvalue()
