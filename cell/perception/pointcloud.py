"""Seeing the meat: a depth image and its tissue mask become a world-frame point cloud and a
triangular surface mesh.

A pixel (u, v) of depth z lies in the camera frame at x = (u + 1/2 - W/2) z / f,
y = -(v + 1/2 - H/2) z / f, -z (MuJoCo cameras look along -z, y up), with
f = H / (2 tan(fovy / 2)); the camera pose maps it to the world. The organised pixel grid gives
the mesh its connectivity for free; triangles that straddle a depth jump (an occlusion edge, a
gap wider than the binning smooths over) are left out, so the mesh breaks there instead of
bridging it.

:func:`capture` renders the view (:mod:`cell.perception.pipeline` shows it on the cell);
a view given as an array meshes alike.

Example:
    >>> import numpy as np
    >>> depth_m = np.full((6, 8), 0.5)
    >>> depth_m[:, 4:] = 0.9  # a step 0.4 m down: an occlusion edge
    >>> mesh = depth_mesh(DepthView(depth_m, 10.0, np.zeros(3), np.eye(3)))
    >>> len(mesh.vertices_m), len(mesh.triangles)  # two patches of 6 x 4, none across the step
    (48, 60)
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from cell.errors import InputError, PerceptionError
from cell.robots.camera import CameraRig


@dataclass(frozen=True)
class SensorNoise:
    """A structured-light depth sensor's errors, applied to a rendered (exact) depth image.

    The depth noise is Gaussian along the optical axis with a standard deviation growing with
    the square of the depth, as triangulation error does (Khoshelham and Oude Elberink 2012
    found a Kinect's random error growing so, to about 4 cm at 5 m: 1.6 mm at 1 m); dropouts
    are pixels that return no depth (specular spots, pattern not decoded).

    Attributes:
        sigma_at_1m_m: standard deviation of the depth error at 1 m depth, in m; at depth z it
            is ``sigma_at_1m_m * z**2`` (z in m).
        dropout_fraction: probability that a pixel returns no depth, in [0, 1).

    Raises:
        InputError: a negative sigma or a dropout fraction outside [0, 1).

    Example:
        >>> import numpy as np
        >>> depth_m = np.full((100, 100), 0.5)
        >>> noisy_m = SensorNoise(sigma_at_1m_m=1e-3).apply(depth_m, np.random.default_rng(0))
        >>> float(np.nanstd(noisy_m)) < 0.001, bool(np.isnan(noisy_m).any())  # 0.25 mm, dropouts
        (True, True)
    """

    sigma_at_1m_m: float = 1.5e-3
    dropout_fraction: float = 0.02

    def __post_init__(self) -> None:
        if not self.sigma_at_1m_m >= 0.0:
            raise InputError(None, "sigma_at_1m_m", f"must be >= 0, got {self.sigma_at_1m_m}")
        if not 0.0 <= self.dropout_fraction < 1.0:
            raise InputError(
                None, "dropout_fraction", f"must be in [0, 1), got {self.dropout_fraction}"
            )

    def apply(self, depth_m: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """A noisy copy of ``depth_m`` (H, W), m; dropped pixels are NaN."""
        depth = np.asarray(depth_m, dtype=float)
        noisy = depth + rng.standard_normal(depth.shape) * (self.sigma_at_1m_m * depth**2)
        noisy[rng.random(depth.shape) < self.dropout_fraction] = np.nan
        return noisy


@dataclass(frozen=True, eq=False)
class DepthView:
    """One organised depth image of the meat with the camera that took it.

    Attributes:
        depth_m: (H, W) depth along the optical axis in m; NaN where the pixel does not see
            tissue or returned no depth.
        focal_px: focal length in pixels, f = H / (2 tan(fovy / 2)).
        position_m: (3,) world position of the camera, m.
        rotation: (3, 3) world orientation of the camera frame (it looks along its -z).

    Example:
        >>> import numpy as np
        >>> view = DepthView(np.full((4, 4), 0.5), 2.0, np.zeros(3), np.eye(3))  # looks down -z
        >>> view.points_m()[0]  # the top left pixel's point, m
        array([-0.375,  0.375, -0.5  ])
        >>> view.points_m(bin_px=2).shape
        (4, 3)
    """

    depth_m: np.ndarray
    focal_px: float
    position_m: np.ndarray
    rotation: np.ndarray

    def __post_init__(self) -> None:
        if np.ndim(self.depth_m) != 2:
            raise InputError(None, "depth_m", f"must be (H, W), got {np.shape(self.depth_m)}")
        if not self.focal_px > 0.0:
            raise InputError(None, "focal_px", f"must be > 0, got {self.focal_px}")

    def grid_points_m(self, bin_px: int = 1) -> np.ndarray:
        """(H // bin_px, W // bin_px, 3) world points of the pixel grid, NaN where no depth.

        With ``bin_px`` > 1, each bin_px x bin_px block becomes one point on its centre
        pixel's ray at the median of its valid depths: the median cuts the sensor noise, and
        a narrow strip of pixels that see past an edge (into the gap between the muscles) stays
        a minority of a 4 x 4 block and drops out. A block with fewer than half its pixels
        valid is NaN, so the outline does not grow into the background.

        Raises:
            InputError: ``bin_px`` not a positive integer.
        """
        if not (isinstance(bin_px, int) and bin_px >= 1):
            raise InputError(None, "bin_px", f"must be an integer >= 1, got {bin_px!r}")
        height, width = self.depth_m.shape
        rows, cols = height // bin_px, width // bin_px
        blocks = self.depth_m[: rows * bin_px, : cols * bin_px].reshape(rows, bin_px, cols, bin_px)
        blocks = blocks.transpose(0, 2, 1, 3).reshape(rows, cols, bin_px * bin_px)
        enough = np.count_nonzero(np.isfinite(blocks), axis=2) * 2 >= bin_px * bin_px
        depth = np.full((rows, cols), np.nan)
        depth[enough] = np.nanmedian(blocks[enough], axis=1)
        # Centre of a block in pixel coordinates (the mean of its pixel indices).
        u = np.arange(cols) * bin_px + (bin_px - 1) / 2.0
        v = np.arange(rows) * bin_px + (bin_px - 1) / 2.0
        x = (u[None, :] + 0.5 - width / 2.0) * depth / self.focal_px
        y = -(v[:, None] + 0.5 - height / 2.0) * depth / self.focal_px
        camera = np.stack([x, y, -depth], axis=-1)
        return camera @ self.rotation.T + self.position_m

    def points_m(self, bin_px: int = 1) -> np.ndarray:
        """(N, 3) world points of the pixels (or bins) that have a depth, row by row (see
        :meth:`grid_points_m`)."""
        grid = self.grid_points_m(bin_px)
        return grid[np.isfinite(grid[..., 2])]


def capture(
    rig: CameraRig,
    data: mujoco.MjData,
    noise: SensorNoise | None = None,
    rng: np.random.Generator | None = None,
) -> DepthView:
    """Render the depth and the tissue mask of ``rig`` and keep the tissue pixels.

    Args:
        rig: the camera.
        data: the simulation state to render.
        noise: the sensor model; None gives the exact rendered depth.
        rng: random source of the noise, required with ``noise`` (seed it for repeatable runs).

    Raises:
        InputError: ``noise`` given without ``rng``.
        PerceptionError: no pixel sees tissue.
    """
    depth = rig.depth(data).astype(float)
    depth[~rig.tissue_mask(data)] = np.nan
    if not np.isfinite(depth).any():
        raise PerceptionError("the camera sees no tissue: no flex pixel in the segmentation")
    if noise is not None:
        if rng is None:
            raise InputError(None, "rng", "a random generator is needed with a sensor noise")
        depth = noise.apply(depth, rng)
    return DepthView(depth, rig.focal_px, *rig.pose(data))


@dataclass(frozen=True, eq=False)
class SurfaceMesh:
    """A triangular surface mesh in the world frame.

    Attributes:
        vertices_m: (N, 3) vertex positions, m.
        triangles: (M, 3) int vertex indices; a depth mesh winds them counter-clockwise seen
            from its camera, so their right-hand normals face the camera.

    Example:
        >>> import numpy as np
        >>> square = SurfaceMesh(np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]),
        ...                      np.array([[0, 1, 2], [0, 2, 3]]))
        >>> square.triangle_normals()
        array([[0., 0., 1.],
               [0., 0., 1.]])
        >>> SurfaceMesh(np.zeros((2, 3)), np.array([[0, 1, 2]]))
        Traceback (most recent call last):
        cell.errors.InputError: triangles: index a vertex that does not exist
    """

    vertices_m: np.ndarray
    triangles: np.ndarray

    def __post_init__(self) -> None:
        if np.ndim(self.vertices_m) != 2 or np.shape(self.vertices_m)[1] != 3:
            raise InputError(
                None, "vertices_m", f"must be (N, 3), got {np.shape(self.vertices_m)}"
            )
        if np.ndim(self.triangles) != 2 or np.shape(self.triangles)[1] != 3:
            raise InputError(None, "triangles", f"must be (M, 3), got {np.shape(self.triangles)}")
        if len(self.triangles) and not (
            self.triangles.min() >= 0 and self.triangles.max() < len(self.vertices_m)
        ):
            raise InputError(None, "triangles", "index a vertex that does not exist")

    def triangle_normals(self) -> np.ndarray:
        """(M, 3) right-hand normals of the triangles scaled by twice their area, m^2."""
        a, b, c = np.moveaxis(self.vertices_m[self.triangles], 1, 0)
        return np.cross(b - a, c - a)


def depth_mesh(view: DepthView, bin_px: int = 1, max_depth_slope: float = 4.0) -> SurfaceMesh:
    """Triangulate the organised depth grid of ``view`` (binned by ``bin_px``, see
    :meth:`DepthView.grid_points_m`) into a surface mesh.

    Each grid quad splits into two triangles along the diagonal of smaller depth difference; a
    triangle is kept only if its three corners have a depth and no edge climbs more than
    ``max_depth_slope`` times the lateral footprint of a grid step (``bin_px * z / f``, so the
    threshold is relative to depth). The default 4 (76 degrees from the view direction) keeps
    every wall the camera sees at a reasonable angle and breaks at occlusion edges.

    Raises:
        InputError: a non-positive ``max_depth_slope`` or a bad ``bin_px``.
        PerceptionError: fewer than three grid points have a depth.
    """
    if not max_depth_slope > 0.0:
        raise InputError(None, "max_depth_slope", f"must be > 0, got {max_depth_slope}")
    grid = view.grid_points_m(bin_px)
    depth = (grid - view.position_m) @ -view.rotation[:, 2]
    valid = np.isfinite(depth)
    if np.count_nonzero(valid) < 3:
        raise PerceptionError(
            f"the depth image has {np.count_nonzero(valid)} points with a depth; a surface "
            "needs at least 3"
        )
    index = np.full(depth.shape, -1, dtype=np.int64)
    index[valid] = np.arange(np.count_nonzero(valid))
    # Quad corners: top-left, bottom-left, top-right, bottom-right in image rows/columns.
    corners = [(slice(None, -1), slice(None, -1)), (slice(1, None), slice(None, -1)),
               (slice(None, -1), slice(1, None)), (slice(1, None), slice(1, None))]
    tl, bl, tr, br = (index[c].ravel() for c in corners)
    ztl, zbl, ztr, zbr = (depth[c].ravel() for c in corners)
    step_m = max_depth_slope * bin_px / view.focal_px  # per metre of depth

    def fits(*zs: np.ndarray) -> np.ndarray:
        with np.errstate(invalid="ignore"):
            nearest = np.minimum.reduce(zs)
            return np.maximum.reduce(zs) - nearest <= step_m * nearest  # NaN corner: False

    # Candidate triangles, all counter-clockwise as seen from the camera: (a, b) split the quad
    # along bottom-left/top-right, (c, d) along top-left/bottom-right.
    candidates = [
        ((tl, bl, tr), fits(ztl, zbl, ztr)),
        ((bl, br, tr), fits(zbl, zbr, ztr)),
        ((tl, bl, br), fits(ztl, zbl, zbr)),
        ((tl, br, tr), fits(ztl, zbr, ztr)),
    ]
    ok = [fit for _, fit in candidates]
    with np.errstate(invalid="ignore"):
        flatter = np.abs(zbl - ztr) <= np.abs(ztl - zbr)
    count_1 = ok[0].astype(int) + ok[1]
    count_2 = ok[2].astype(int) + ok[3]
    use_1 = (count_1 > count_2) | ((count_1 == count_2) & flatter)
    keep = [ok[0] & use_1, ok[1] & use_1, ok[2] & ~use_1, ok[3] & ~use_1]
    triangles = np.concatenate(
        [np.stack(ids, axis=1)[k] for (ids, _), k in zip(candidates, keep, strict=True)]
    ).reshape(-1, 3)
    # Points left without a triangle (islands cut off by jumps) carry no surface.
    used = np.zeros(len(index[valid]), dtype=bool)
    used[triangles] = True
    if not used.any():
        raise PerceptionError("no three neighbouring depth points form a triangle")
    return SurfaceMesh(grid[valid][used], (np.cumsum(used) - 1)[triangles])

