"""Headless images from the cell's camera: RGB, metric depth, segmentation."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from cell.errors import PerceptionError
from cell.profiling import timed


class CameraRig:
    """Renders one MuJoCo camera offscreen (EGL or OSMesa, see ``MUJOCO_GL``); a context
    manager that frees its GL context on leaving.

    Example:
        >>> import mujoco
        >>> spec = mujoco.MjSpec()
        >>> _ = spec.worldbody.add_camera(name="eye", pos=[0.0, 0.0, 1.0])  # looks down
        >>> _ = spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[1.0, 1.0, 0.01])
        >>> model = spec.compile()
        >>> data = mujoco.MjData(model)
        >>> mujoco.mj_forward(model, data)
        >>> with CameraRig(model, "eye", 64, 48) as rig:
        ...     depth_m = rig.depth(data)
        >>> depth_m.shape, round(float(depth_m[24, 32]), 3)  # the box's top, 0.01 m high
        ((48, 64), 0.99)
    """

    @timed("perception")  # the renderer's GL context
    def __init__(self, model: mujoco.MjModel, camera: str, width_px: int,
                 height_px: int) -> None:
        self.model = model
        self.camera_id = model.camera(camera).id
        self.width_px = width_px
        self.height_px = height_px
        try:
            self.renderer = mujoco.Renderer(model, height_px, width_px)
        except Exception as exc:  # MuJoCo raises plain errors for a missing GL platform
            raise PerceptionError(
                f"cannot render headless ({exc}); set MUJOCO_GL=egl (or osmesa) before "
                "mujoco is imported") from exc

    @property
    def focal_px(self) -> float:
        """Focal length in pixels: f = H / (2 tan(fovy / 2))."""
        fovy = math.radians(float(self.model.cam_fovy[self.camera_id]))
        return self.height_px / (2.0 * math.tan(fovy / 2.0))

    def pose(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """World position (3,) m and rotation (3, 3) of the camera (MuJoCo: looks along -z)."""
        return (data.cam_xpos[self.camera_id].copy(),
                data.cam_xmat[self.camera_id].reshape(3, 3).copy())

    def rgb(self, data: mujoco.MjData) -> np.ndarray:
        """(H, W, 3) uint8 colour image."""
        self.renderer.update_scene(data, self.camera_id)
        return self.renderer.render()

    def depth(self, data: mujoco.MjData) -> np.ndarray:
        """(H, W) float32 depth along the optical axis, m."""
        return self._render_in_mode(data, "depth")

    def segmentation(self, data: mujoco.MjData) -> np.ndarray:
        """(H, W, 2) int32 object id and :class:`mujoco.mjtObj` type per pixel (-1: none)."""
        return self._render_in_mode(data, "segmentation")

    def _render_in_mode(self, data: mujoco.MjData, mode: str) -> np.ndarray:
        """Render with the renderer switched to ``mode`` and back, even on an error."""
        getattr(self.renderer, f"enable_{mode}_rendering")()
        try:
            self.renderer.update_scene(data, self.camera_id)
            return self.renderer.render()
        finally:
            getattr(self.renderer, f"disable_{mode}_rendering")()

    def tissue_mask(self, data: mujoco.MjData) -> np.ndarray:
        """(H, W) bool: pixels that see one of the muscles (a flex)."""
        seg = self.segmentation(data)
        return seg[..., 1] == int(mujoco.mjtObj.mjOBJ_FLEX)

    def close(self) -> None:
        """Free the GL context."""
        self.renderer.close()

    def __enter__(self) -> CameraRig:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
