"""The valley's floor found on the full-resolution cloud, under the walked guideline.

The walk (:mod:`cell.perception.guideline`) steps from node to node of the binned depth mesh,
about 8 mm apart on the default camera, and the spline through its nodes can lie millimetres
across from the valley's floor where the valley runs shallow towards the meat's tapered ends
(most at the guideline's first point, little in the middle). At the blade's entry that error
adds to the lean's. At each guideline sample, the
cloud's points in a patch around it (before binning) are fitted with two planar walls that
meet in a crease along the guideline, the crease searched across; the sample moves onto it,
the creases' offsets smoothed by a running median. The crease, not a parabola: the meat's
surface is a mesh whose two muscles meet at the interface's top vertices with walls of
unequal slope, and a real crease between two muscles is as sharp, whereas a parabola's vertex
leans towards the gentler wall. A fit whose walls do not both rise (the valley has run out at
the end's edge) or whose crease lies farther than ``max_shift_m`` from the walk is not
trusted: the sample takes the nearest trusted sample's offset instead.

Example (a crease with walls of unequal slope, 3 mm off the walked line y = 0):
    >>> rng = np.random.default_rng(0)
    >>> x, y = rng.uniform(-0.1, 0.1, 4000), rng.uniform(-0.03, 0.03, 4000)
    >>> cloud = np.column_stack([x, y, np.where(y < 0.003, -0.4, 0.2) * (y - 0.003)])
    >>> line = np.column_stack([np.linspace(-0.05, 0.05, 11), np.zeros(11), np.zeros(11)])
    >>> path = CutPath(line, np.tile([1.0, 0.0, 0.0], (11, 1)),
    ...                np.tile([0.0, 0.0, 1.0], (11, 1)), np.arange(11))
    >>> floor = find_floor(path, cloud, FloorParams())
    >>> np.round(floor.points_m[[0, 5, -1], 1], 3)
    array([0.003, 0.003, 0.003])
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.ndimage import median_filter
from scipy.spatial import cKDTree

from cell.config import require_count, require_flag, require_positive
from cell.perception.guideline import CutPath
from cell.polyline import arc_lengths

#: The crease's position across is searched on this grid, m.
_CREASE_STEP_M = 0.0005
#: Keeps the walls' normal equations solvable where a candidate crease leaves no point on
#: one side (m^2, far below the terms' own scale).
_RIDGE = 1e-12
#: Points farther from a fit than this many times its median distance (but at least
#: _LEAST_OUTLIER_M) are left out of the next: the camera sees down the gap between the
#: muscles, 1 to 5 cm below the floor, in a few pixels.
_OUTLIER_SPREAD = 4.0
_LEAST_OUTLIER_M = 0.001
#: The trusted floors' offsets are a running median over this many samples: a patch holds
#: about 50 points on the default camera, and one in a few fits lands 2-3 mm off.
_MEDIAN_SAMPLES = 5
#: Fits per sample, each on the patch recentred on the last one's crease and without its
#: outliers: a patch centred off the floor holds more of one wall than of the other.
_ROUNDS = 3


@dataclass(frozen=True)
class FloorParams:
    """Where the guideline's samples look for the valley's floor (SI units).

    Attributes:
        enabled: move the samples to the floor; false keeps the walk's spline.
        half_length_m: the patch's half length along the guideline, m.
        half_width_m: the patch's half width across it, m: wider than the walk's error, narrow
            enough that the walls stay about planar across it.
        min_points: the fewest cloud points a patch's fit takes.
        max_shift_m: a floor farther than this from the walked sample is not trusted, m.

    Raises:
        InputError: a non-positive size, or a point count under 6 (the walls have four terms).

    Example:
        >>> FloorParams(half_width_m=0.01).max_shift_m
        0.006
    """

    enabled: bool = True
    half_length_m: float = 0.008
    half_width_m: float = 0.012
    min_points: int = 15
    max_shift_m: float = 0.006

    def __post_init__(self) -> None:
        require_flag(self, "enabled")
        require_positive(self, "half_length_m", "half_width_m", "max_shift_m")
        require_count(self, "min_points", 6)


def _walls(u: np.ndarray, v: np.ndarray, crease_m: np.ndarray) -> np.ndarray:
    """(C, N, 4) the terms of two planar walls meeting in a crease along the guideline, at
    each of ``crease_m`` (C,) across from it: h = a + b u + left min(v - c, 0) + right
    max(v - c, 0)."""
    offset = v[None, :] - np.asarray(crease_m, dtype=float).reshape(-1, 1)
    ones = np.ones_like(offset)
    return np.stack([ones, ones * u, np.minimum(offset, 0.0), np.maximum(offset, 0.0)], axis=2)


def _crease(u: np.ndarray, v: np.ndarray, h: np.ndarray) -> tuple[float, np.ndarray] | None:
    """Where across (m) two walls that rise on both sides fit the heights ``h`` best, the
    crease searched on a grid, and the walls' coefficients; None where no such pair fits
    (not a valley)."""
    candidates = np.arange(v.min(), v.max(), _CREASE_STEP_M)
    if len(candidates) == 0:  # every point on one line along the guideline
        return None
    terms = _walls(u, v, candidates)
    normal = np.einsum("cni,cnj->cij", terms, terms) + _RIDGE * np.eye(4)
    coef = np.linalg.solve(normal, np.einsum("cni,n->ci", terms, h)[..., None])[..., 0]
    cost = np.square(h - np.einsum("cni,ci->cn", terms, coef)).sum(axis=1)
    cost[~((coef[:, 2] < 0.0) & (coef[:, 3] > 0.0))] = np.inf
    best = int(np.argmin(cost))
    return None if not np.isfinite(cost[best]) else (float(candidates[best]), coef[best])


def _floor_at(patch: cKDTree, cloud_m: np.ndarray, point: np.ndarray, tangent: np.ndarray,
              across: np.ndarray, normal: np.ndarray, reach_m: tuple[float, float],
              params: FloorParams) -> float | None:
    """The floor's offset across (m) from ``point``, the patch reaching ``reach_m`` back and
    ahead along the guideline (m); None if the patch has no trusted floor."""
    radius = float(np.hypot(params.half_length_m, params.half_width_m + params.max_shift_m))
    near = cloud_m[patch.query_ball_point(point[:2], radius)] - point
    u, v, h = near @ tangent, near @ across, near @ normal
    along = ((u >= -min(reach_m[0], params.half_length_m))
             & (u <= min(reach_m[1], params.half_length_m)))
    centre, inlier = 0.0, np.ones(len(u), dtype=bool)
    for _ in range(_ROUNDS):
        inside = along & inlier & (np.abs(v - centre) <= params.half_width_m)
        if inside.sum() < params.min_points:
            return None
        found = _crease(u[inside], v[inside], h[inside])
        if found is None:
            return None
        crease, coef = found
        residual = np.abs(h - _walls(u, v, crease)[0] @ coef)
        inlier = residual <= max(_OUTLIER_SPREAD * float(np.median(residual[inside])),
                                 _LEAST_OUTLIER_M)
        centre = crease
        if abs(centre) > params.max_shift_m:
            return None
    return centre


def find_floor(path: CutPath, cloud_m: np.ndarray, params: FloorParams) -> CutPath:
    """``path`` with each sample moved across onto the valley's floor in ``cloud_m`` (N, 3),
    the unbinned cloud (world, m); samples without a trusted floor take the nearest trusted
    one's move, and with none at all the path is returned as it was."""
    if not params.enabled:
        return path
    cloud = np.asarray(cloud_m, dtype=float)
    patch = cKDTree(cloud[:, :2])
    across = np.cross(path.normals, path.tangents)
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    station = arc_lengths(path.points_m)
    # The patch stays within the guideline's own length: past its ends lie the meat's end
    # face and the table.
    reach = np.column_stack([station, station[-1] - station])
    found = [_floor_at(patch, cloud, *frame, params) for frame in
             zip(path.points_m, path.tangents, across, path.normals, reach, strict=True)]
    trusted = np.flatnonzero([offset is not None for offset in found])
    if len(trusted) == 0:
        return path
    offsets = np.array([found[i] for i in trusted])
    if len(offsets) >= _MEDIAN_SAMPLES:  # mirroring needs the window's length
        offsets = median_filter(offsets, _MEDIAN_SAMPLES, mode="mirror")
    nearest = np.abs(np.arange(len(found))[:, None] - trusted).argmin(axis=1)
    return replace(path, points_m=path.points_m + offsets[nearest, None] * across)
