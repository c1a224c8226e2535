"""Fitting the generic two-muscle model to a perceived point cloud (paper Sec. 3.1), and what
the fitted model predicts about the hidden interface.

The generic model is the outer surface (boundary triangles) of
:func:`~cell.tissue.geometry.build_two_muscles`. It is fitted with the paper's twelve parameters: an
affine map x -> A (x - c) + c + t about the model's centroid c, with A = R S, R a rotation
(three angles) and S upper triangular (three scales on its diagonal, three shears above it),
and t a translation. A = R S is the QR factorisation of A, one-to-one for det A > 0, so the
solver works on the twelve entries of A and t directly: the residuals are then linear in them
and their Jacobian exact for given correspondences.

The residual of a cloud point p is its signed distance to the plane of the closest model
triangle, mapped by the current estimate (point-to-plane, which lets the cloud slide along the
surface); correspondences are found again in every round, in the model's own frame (the cloud
mapped back by the inverse affine map) where the triangles do not move, and each round solves
the linear weighted least-squares problem exactly (point-to-plane ICP with a Gauss-Newton step).
A robust (Cauchy) loss keeps stray points (the table, a tool) from pulling the fit.

Example:
    >>> import numpy as np
    >>> from cell.tissue.geometry import MuscleShape, build_two_muscles
    >>> model = build_two_muscles(MuscleShape(cell_size_m=0.05), origin_m=(0.0, 0.0, 0.6))
    >>> cloud_m = model_surface(model).vertices_m + [0.01, -0.005, 0.0]  # the meat, moved
    >>> fit = fit_generic_model(cloud_m, model)
    >>> fit.translation_m.round(4) + 0.0  # the move, found
    array([ 0.01 , -0.005,  0.   ])
    >>> top_m = model.top_line + [0.01, -0.005, 0.0]
    >>> depth_m = predict_interface(fit, model).depth_below(top_m)  # from the top to the table
    >>> bool(np.allclose(depth_m, top_m[:, 2] - 0.6, atol=1e-5))  # the table is at 0.6 m
    True
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from cell.errors import InputError, PerceptionError
from cell.perception.pointcloud import SurfaceMesh
from cell.polyline import closest_on
from cell.tissue.geometry import TwoMuscleMesh

# Closest triangles are sought among those whose centroids are nearest a point; the model's
# triangles are of similar size, and this many candidates always held the closest in tests.
_CANDIDATE_TRIANGLES = 12


@dataclass(frozen=True)
class FitParams:
    """How the generic model is fitted (SI units).

    Attributes:
        robust_scale_m: distance f beyond which a cloud point counts less than quadratically
            (the Cauchy loss f^2 log(1 + (d / f)^2), applied as weights); about the sensor's
            noise plus the model's misfit.
        max_iterations: most correspondence-and-solve rounds.
        tolerance_m: stop once no model vertex moves more than this in a round, m. On a noisy
            cloud the correspondences keep switching and the vertices move a fraction of a
            millimetre a round about the solution for good, so a finer tolerance only spends
            rounds.

    Raises:
        InputError: a non-positive value.

    Example:
        >>> FitParams(robust_scale_m=0.005).max_iterations
        30
    """

    robust_scale_m: float = 0.002
    max_iterations: int = 30
    tolerance_m: float = 1e-4

    def __post_init__(self) -> None:
        for name in ("robust_scale_m", "max_iterations", "tolerance_m"):
            if not getattr(self, name) > 0:
                raise InputError(None, name, f"must be > 0, got {getattr(self, name)}")


@dataclass(frozen=True, eq=False)
class AffineFit:
    """A fitted affine map x -> A (x - c) + c + t of the generic model onto the cloud.

    Attributes:
        matrix: (3, 3) A = R S.
        translation_m: (3,) t, m.
        pivot_m: (3,) c, the generic model's centroid, m.
        rms_m: root-mean-square point-to-surface distance of the cloud in the last round, m.

    Example:
        >>> import numpy as np
        >>> turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90 deg about z
        >>> fit = AffineFit(turn * 2.0, np.zeros(3), np.zeros(3), rms_m=0.0)
        >>> fit.rotation_vector_rad.round(4), np.diag(fit.scale_shear)
        (array([0.    , 0.    , 1.5708]), array([2., 2., 2.]))
        >>> fit.apply(np.array([1.0, 0.0, 0.0]))
        array([0., 2., 0.])
    """

    matrix: np.ndarray
    translation_m: np.ndarray
    pivot_m: np.ndarray
    rms_m: float

    def apply(self, points_m: np.ndarray) -> np.ndarray:
        """Map (..., 3) model points to the world, m."""
        return (np.asarray(points_m) - self.pivot_m) @ self.matrix.T + self.pivot_m + (
            self.translation_m
        )

    @property
    def _qr(self) -> tuple[np.ndarray, np.ndarray]:
        rotation, upper = np.linalg.qr(self.matrix)
        signs = np.sign(np.diag(upper))
        return rotation * signs, upper * signs[:, None]

    @property
    def rotation(self) -> np.ndarray:
        """(3, 3) R of A = R S (a proper rotation while det A > 0)."""
        return self._qr[0]

    @property
    def scale_shear(self) -> np.ndarray:
        """(3, 3) S of A = R S: upper triangular, scales on the diagonal, shears above it."""
        return self._qr[1]

    @property
    def rotation_vector_rad(self) -> np.ndarray:
        """(3,) the three rotation parameters: axis times angle, rad."""
        return Rotation.from_matrix(self.rotation).as_rotvec()


def model_surface(model: TwoMuscleMesh) -> SurfaceMesh:
    """The generic model's outer surface: both muscles' boundary triangles, wound outward."""
    round_points = model.round.points
    return SurfaceMesh(
        np.concatenate([round_points, model.shank.points]),
        np.concatenate([model.round.boundary, model.shank.boundary + len(round_points)]),
    )


def closest_on_triangles(
    points: np.ndarray, corners: np.ndarray, candidates: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Closest point to each of ``points`` (N, 3) on its ``candidates`` (N, K) triangles,
    whose ``corners`` are (T, 3, 3); returns the points (N, 3) and the triangle ids (N,), the
    first candidate of a row where two lie as close."""
    points = np.ascontiguousarray(points, dtype=float)
    closest = np.empty((len(points), 3))
    triangle = np.empty(len(points), dtype=np.int64)
    _closest_on_triangles(points, np.ascontiguousarray(corners, dtype=float),
                          np.ascontiguousarray(candidates, dtype=np.int64), closest, triangle)
    return closest, triangle


@njit(cache=True)
def _closest_on_triangles(points: np.ndarray, corners: np.ndarray, candidates: np.ndarray,
                          closest: np.ndarray, triangle: np.ndarray) -> None:
    """Compiled, in scalars: the cut's score asks it every control step and the registration
    for every point of the cloud; numpy's temporaries cost more than the arithmetic."""
    best = np.empty(3)
    for n in range(points.shape[0]):
        best_distance = np.inf
        for k in range(candidates.shape[1]):
            t = candidates[n, k]
            distance = _closest_on_triangle(points[n], corners[t], best)
            if distance < best_distance or k == 0:
                best_distance = distance
                closest[n] = best
                triangle[n] = t


@njit(cache=True)
def _closest_on_triangle(p: np.ndarray, corners: np.ndarray, out: np.ndarray) -> float:
    """The closest point to ``p`` on the triangle of ``corners`` (3, 3), into ``out``, and its
    distance: the projection on the triangle's plane where that lies inside, else the nearest
    of its edges' closest points."""
    a, b, c = corners[0], corners[1], corners[2]
    n0, n1, n2 = _cross(b[0] - a[0], b[1] - a[1], b[2] - a[2], c[0] - a[0], c[1] - a[1],
                        c[2] - a[2])
    length = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    n0, n1, n2 = n0 / length, n1 / length, n2 / length
    height = (p[0] - a[0]) * n0 + (p[1] - a[1]) * n1 + (p[2] - a[2]) * n2
    q0, q1, q2 = p[0] - height * n0, p[1] - height * n1, p[2] - height * n2
    inside = True
    for e in range(3):
        s, f = corners[e], corners[(e + 1) % 3]
        s0, s1, s2 = _cross(f[0] - s[0], f[1] - s[1], f[2] - s[2], q0 - s[0], q1 - s[1],
                            q2 - s[2])
        inside &= s0 * n0 + s1 * n1 + s2 * n2 >= 0.0
    if inside:
        out[0], out[1], out[2] = q0, q1, q2
        return np.sqrt((q0 - p[0]) ** 2 + (q1 - p[1]) ** 2 + (q2 - p[2]) ** 2)
    nearest = np.inf
    out[:] = np.nan  # stays so where the corners coincide (no edge has a length)
    for e in range(3):
        s, f = corners[e], corners[(e + 1) % 3]
        d0, d1, d2 = f[0] - s[0], f[1] - s[1], f[2] - s[2]
        along = (((p[0] - s[0]) * d0 + (p[1] - s[1]) * d1 + (p[2] - s[2]) * d2)
                 / (d0 * d0 + d1 * d1 + d2 * d2))
        along = min(max(along, 0.0), 1.0)
        e0, e1, e2 = s[0] + along * d0, s[1] + along * d1, s[2] + along * d2
        distance = np.sqrt((e0 - p[0]) ** 2 + (e1 - p[1]) ** 2 + (e2 - p[2]) ** 2)
        if distance < nearest:
            nearest = distance
            out[0], out[1], out[2] = e0, e1, e2
    return nearest


@njit(cache=True)
def _cross(u0: float, u1: float, u2: float, v0: float, v1: float, v2: float
           ) -> tuple[float, float, float]:
    return u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0


def fit_generic_model(
    cloud_m: np.ndarray,
    model: TwoMuscleMesh,
    params: FitParams | None = None,
    initial: AffineFit | None = None,
) -> AffineFit:
    """Fit the twelve parameters that map ``model``'s surface onto ``cloud_m`` (N, 3), m.

    Build ``model`` where the meat is expected (``origin_m`` of
    :func:`~cell.tissue.geometry.build_two_muscles`): the fit starts from the identity (or
    ``initial``) and converges from rotations of several degrees and offsets of centimetres.

    Raises:
        PerceptionError: fewer than twelve cloud points (too few for twelve parameters), or a
            fit that mirrors the model.
    """
    params = FitParams() if params is None else params
    cloud = np.asarray(cloud_m, dtype=float).reshape(-1, 3)
    if len(cloud) < 12:
        raise PerceptionError(f"the cloud has {len(cloud)} points; a 12-parameter fit needs 12")
    surface = model_surface(model)
    corners = surface.vertices_m[surface.triangles]
    normals = surface.triangle_normals()
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    centroid_tree = cKDTree(corners.mean(axis=1))
    pivot = surface.vertices_m.mean(axis=0)
    matrix = np.eye(3) if initial is None else initial.matrix.copy()
    translation = np.zeros(3) if initial is None else initial.translation_m.copy()
    for _ in range(params.max_iterations):
        # Correspondences in the model's frame, where the triangles stay put.
        in_model = np.linalg.solve(matrix, (cloud - pivot - translation).T).T + pivot
        _, near = centroid_tree.query(in_model, k=min(_CANDIDATE_TRIANGLES, len(corners)))
        closest, triangle = closest_on_triangles(in_model, corners, near.reshape(len(cloud), -1))
        world_normals = np.linalg.solve(matrix.T, normals[triangle].T).T  # A^-T n, row-wise
        world_normals /= np.linalg.norm(world_normals, axis=1, keepdims=True)
        # r = n . (p - c) - n . (A (q - c)) - n . t is linear in (A, t) for fixed q and n.
        jacobian = np.concatenate(
            [(world_normals[:, :, None] * (closest - pivot)[:, None, :]).reshape(-1, 9),
             world_normals], axis=1,
        )
        target = np.einsum("ij,ij->i", world_normals, cloud - pivot)
        current = np.concatenate([matrix.ravel(), translation])
        residual = target - jacobian @ current
        # Iteratively reweighted least squares with the Cauchy loss, rho(d) = f^2 log(1 +
        # (d / f)^2), of the full distance d to the closest point: a stray point on the plane
        # of a face but beyond its edge (the table beside the meat) is far, not on the surface.
        distance = np.linalg.norm(cloud - (closest - pivot) @ matrix.T - pivot - translation,
                                  axis=1)
        weights = 1.0 / np.sqrt(1.0 + (distance / params.robust_scale_m) ** 2)
        # The 12 x 12 normal equations: a tenth of lstsq's time on a thousand points.
        weighted = weights[:, None] * jacobian
        solution = np.linalg.solve(weighted.T @ weighted, weighted.T @ (weights * target))
        moved = (surface.vertices_m - pivot) @ (solution[:9].reshape(3, 3) - matrix).T + (
            solution[9:] - translation
        )
        matrix, translation = solution[:9].reshape(3, 3), solution[9:]
        if np.max(np.linalg.norm(moved, axis=1)) < params.tolerance_m:
            break
    if not np.linalg.det(matrix) > 0.0:
        raise PerceptionError(
            "the fit turned the generic model inside out (det A <= 0): the cloud does not "
            "constrain it; place the model closer to the meat or give a fuller view"
        )
    return AffineFit(matrix, translation, pivot, float(np.sqrt(np.mean(residual**2))))


@dataclass(frozen=True, eq=False)
class InterfacePrediction:
    """The hidden interface (aponeurosis mid-surface) as the fitted model places it.

    Attributes:
        surface_m: (U, W, 3) the midpoints of the model's facing vertex pairs, mapped by the
            fit: U stations along the muscles, W levels from the table (0) to the top (W - 1).

    Example:
        >>> import numpy as np
        >>> from cell.tissue.geometry import MuscleShape, build_two_muscles
        >>> model = build_two_muscles(MuscleShape(cell_size_m=0.05))
        >>> prediction = predict_interface(AffineFit(np.eye(3), np.zeros(3), np.zeros(3), 0.0),
        ...                                model)  # the model's own interface
        >>> prediction.top_line_m.shape == model.top_line.shape
        True
    """

    surface_m: np.ndarray

    @property
    def top_line_m(self) -> np.ndarray:
        """(U, 3) the interface's top edge, at the bottom of the valley, m."""
        return self.surface_m[:, -1]

    @property
    def bottom_line_m(self) -> np.ndarray:
        """(U, 3) the interface's bottom edge, on the table, m."""
        return self.surface_m[:, 0]

    def depth_below(self, points_m: np.ndarray) -> np.ndarray:
        """(K,) how far the interface reaches below each of ``points_m`` (K, 3), in m along
        world z: the height of each point above the interface's bottom edge at the same place
        along the muscles (the point projected onto the top line in the xy-plane), which is
        how deep a cut from that point must go to part the muscles there."""
        points = np.asarray(points_m, dtype=float).reshape(-1, 3)
        closest = closest_on(points[:, :2], self.top_line_m[:, :2])
        segment, fraction, bottom = closest.segment, closest.fraction, self.bottom_line_m
        floor = (1.0 - fraction) * bottom[segment, 2] + fraction * bottom[segment + 1, 2]
        return points[:, 2] - floor


def predict_interface(fit: AffineFit, model: TwoMuscleMesh) -> InterfacePrediction:
    """Map ``model``'s interface (its facing pairs' midpoints) with ``fit``."""
    stations = len(model.top_line)
    return InterfacePrediction(fit.apply(model.pair_midpoints_m).reshape(stations, -1, 3))
