"""Curvature of a triangular surface mesh from the Cohen-Steiner and Morvan tensor (paper Eq. 11).

At each vertex v the tensor is::

    T(v) = 1 / |B| * sum over edges e of beta(e) |e n B| e_hat e_hat^T

with beta(e) the signed angle between the normals of the two triangles at e (positive where
the surface is convex, that is bends away from its normals), e_hat the unit edge direction and
B the region around v. Here B is the Euclidean ball of radius ``radius_m`` around v, and the
length of e inside B counts each half of e whose end vertex lies in the ball (``|e n B|`` is
``|e|``, ``|e| / 2`` or 0): the midpoint rule for the clipped length, exact when the ball's rim
crosses an edge at its middle. ``|B|`` is, consistently, the area owned by the vertices in the
ball (a third of each triangle to each corner). Both sums are one sparse product of the ball's
vertex adjacency with per-vertex values, so the cost is that of a KD-tree query and one sparse
matrix product.

The paper takes the normal as the tensor's eigenvector of least magnitude and the two other
eigenvalues as the principal curvatures. That eigenvector is undefined wherever the surface is
developable (a cylinder, the crease of the valley, a flat facet of the rendered meat): two
eigenvalues vanish there and any vector of their plane is "least". So the normal here is the
one that eigenvector approximates on a curved surface, the area-weighted normal of the
triangles in B, and the principal curvatures are the eigenvalues of T restricted to the tangent
plane of that normal (a 2 x 2 block, diagonalised in closed form). Each eigenvector is the
direction of the *other* principal curvature: T adds up bending across edges, and the edges
along the direction of least curvature are where the normals turn most.

Example:
    >>> import numpy as np
    >>> from cell.perception.pointcloud import DepthView, depth_mesh
    >>> rows_m = (np.arange(40) - 19.5) * 0.005  # a 2 cm deep groove along x, 0.5 m below
    >>> depth_m = np.tile(0.5 + 0.02 * np.exp(-(rows_m / 0.02) ** 2), (80, 1)).T
    >>> mesh = depth_mesh(DepthView(depth_m, 100.0, np.array([0.0, 0.0, 0.6]), np.eye(3)))
    >>> curv = surface_curvature(mesh, radius_m=0.015)
    >>> valley = curv.mean_1_m < -7.0  # concave: bent towards the camera
    >>> bool(np.all(np.abs(mesh.vertices_m[valley, 1]) < 0.02))
    True
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from cell.errors import InputError, PerceptionError
from cell.perception.pointcloud import SurfaceMesh

# Components of a symmetric 3x3 tensor stored as a 6-vector: xx, yy, zz, xy, xz, yz.
_SYM_ROWS = np.array([0, 1, 2, 0, 0, 1])
_SYM_COLS = np.array([0, 1, 2, 1, 2, 2])


@dataclass(frozen=True, eq=False)
class Curvature:
    """Per-vertex curvature of a surface mesh, in 1/m; positive where it is convex.

    Signs follow the triangles' winding: on a depth mesh (normals towards the camera) a ridge
    is positive and a valley negative; on an outward-wound closed surface a sphere of radius R
    has both principal curvatures +1/R.

    Attributes:
        normals: (N, 3) unit normals, the area-weighted normal of the triangles in the ball
            (on the side their winding gives).
        min_1_m: (N,) least principal curvature.
        max_1_m: (N,) greatest principal curvature.
        min_directions: (N, 3) unit tangent direction of ``min_1_m``.
        max_directions: (N, 3) unit tangent direction of ``max_1_m``.

    Example:
        >>> import numpy as np
        >>> from cell.perception.pointcloud import DepthView, depth_mesh
        >>> flat = depth_mesh(DepthView(np.full((20, 20), 0.5), 100.0, np.zeros(3), np.eye(3)))
        >>> curv = surface_curvature(flat, radius_m=0.015)
        >>> float(np.abs(curv.mean_1_m).max()), curv.normals[0]
        (0.0, array([0., 0., 1.]))
    """

    normals: np.ndarray
    min_1_m: np.ndarray
    max_1_m: np.ndarray
    min_directions: np.ndarray
    max_directions: np.ndarray

    @property
    def mean_1_m(self) -> np.ndarray:
        """(N,) mean curvature (Cmin + Cmax) / 2, 1/m (paper Eq. 12)."""
        return 0.5 * (self.min_1_m + self.max_1_m)

    @property
    def gaussian_1_m2(self) -> np.ndarray:
        """(N,) Gaussian curvature Cmin * Cmax, 1/m^2 (paper Eq. 13)."""
        return self.min_1_m * self.max_1_m


def _ball_adjacency(points_m: np.ndarray, radius_m: float) -> sp.csr_matrix:
    """(N, N) sparse 0/1 matrix: entry (i, j) is 1 where |p_i - p_j| <= ``radius_m`` (i == j
    included)."""
    n = len(points_m)
    pairs = cKDTree(points_m).query_pairs(radius_m, output_type="ndarray")
    rows = np.concatenate([pairs[:, 0], pairs[:, 1], np.arange(n)])
    cols = np.concatenate([pairs[:, 1], pairs[:, 0], np.arange(n)])
    return sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))


def _edge_tensors(mesh: SurfaceMesh) -> tuple[np.ndarray, np.ndarray]:
    """Per-vertex half sums of beta |e| e_hat e_hat^T over the incident edges, (N, 6) 1/m * m^2
    in the ``_SYM_*`` layout, and the (M, 3) area-scaled triangle normals."""
    n = len(mesh.vertices_m)
    tri = mesh.triangles
    face_normals = mesh.triangle_normals()
    tails = tri.ravel()
    heads = tri[:, [1, 2, 0]].ravel()
    faces = np.repeat(np.arange(len(tri)), 3)
    key = np.minimum(tails, heads) * n + np.maximum(tails, heads)
    order = np.argsort(key, kind="stable")
    key = key[order]
    # Two consecutive half-edges with the same key are the two sides of an interior edge; a
    # border edge (one side) or a non-manifold one (three or more) has no defined angle.
    same = key[1:] == key[:-1]
    lone_before = np.concatenate([[True], ~same[:-1]])
    lone_after = np.concatenate([~same[1:], [True]])
    first = np.flatnonzero(same & lone_before & lone_after)
    h1, h2 = order[first], order[first + 1]
    n1, n2 = face_normals[faces[h1]], face_normals[faces[h2]]
    edge = mesh.vertices_m[heads[h1]] - mesh.vertices_m[tails[h1]]
    length = np.linalg.norm(edge, axis=1)
    unit = edge / length[:, None]
    # Signed angle from n1 to n2 about the edge as wound in the first triangle: positive where
    # the surface folds away from its normals (convex).
    beta = np.arctan2(np.einsum("ij,ij->i", np.cross(n1, n2), unit), np.einsum("ij,ij->i", n1, n2))
    weighted = (0.5 * beta * length)[:, None] * unit[:, _SYM_ROWS] * unit[:, _SYM_COLS]
    ends = np.concatenate([tails[h1], heads[h1]])
    incidence = sp.csr_matrix(
        (np.ones(len(ends)), (ends, np.tile(np.arange(len(h1)), 2))), shape=(n, len(h1))
    )
    return incidence @ weighted, face_normals


def _bilinear(flat: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N,) a^T T b for symmetric tensors T stored as (N, 6) in the ``_SYM_*`` layout."""
    xx, yy, zz, xy, xz, yz = flat.T
    tb = np.stack([xx * b[:, 0] + xy * b[:, 1] + xz * b[:, 2],
                   xy * b[:, 0] + yy * b[:, 1] + yz * b[:, 2],
                   xz * b[:, 0] + yz * b[:, 1] + zz * b[:, 2]], axis=1)
    return np.einsum("ij,ij->i", a, tb)


def surface_curvature(mesh: SurfaceMesh, radius_m: float) -> Curvature:
    """Principal curvatures, directions and normals of ``mesh`` at every vertex (module
    docstring: the ball B of radius ``radius_m``, Eq. 11).

    Take ``radius_m`` at least about twice the mean edge length: a smaller ball holds too few
    edges for an even estimate on an uneven mesh, a larger one smooths more (noise as well as
    detail). A vertex whose ball holds no triangle gets zero curvature and a zero normal.

    Raises:
        InputError: ``radius_m`` not > 0.
        PerceptionError: the mesh has no triangle.
    """
    if not radius_m > 0.0:
        raise InputError(None, "radius_m", f"must be > 0, got {radius_m}")
    if len(mesh.triangles) == 0:
        raise PerceptionError("the surface mesh has no triangle: no curvature to estimate")
    n = len(mesh.vertices_m)
    vertex_tensors, face_normals = _edge_tensors(mesh)
    corners = mesh.triangles.ravel()
    corner_normals = np.repeat(face_normals, 3, axis=0)
    per_vertex = np.column_stack(
        [vertex_tensors]
        + [np.bincount(corners, corner_normals[:, k], minlength=n) for k in range(3)]
        # A third of each triangle's area to each corner: |B| is the area of the ball's vertices.
        + [np.bincount(corners, np.linalg.norm(corner_normals, axis=1) / 6.0, minlength=n)]
    )
    in_ball = _ball_adjacency(mesh.vertices_m, radius_m) @ per_vertex
    area = in_ball[:, 9]
    flat = in_ball[:, :6] / np.where(area > 0.0, area, np.inf)[:, None]
    normal_sum = in_ball[:, 6:9]
    length = np.linalg.norm(normal_sum, axis=1, keepdims=True)
    normals = normal_sum / np.where(length > 0.0, length, np.inf)

    # Restrict T to the tangent plane and diagonalise the 2 x 2 block in closed form.
    least = np.argmin(np.abs(normals), axis=1)
    t1 = np.cross(normals, np.eye(3)[least])
    t1 /= np.where(length > 0.0, np.linalg.norm(t1, axis=1, keepdims=True), np.inf)
    t2 = np.cross(normals, t1)
    a, b, c = _bilinear(flat, t1, t1), _bilinear(flat, t1, t2), _bilinear(flat, t2, t2)
    mid, half_diff = 0.5 * (a + c), 0.5 * (a - c)
    spread = np.hypot(half_diff, b)
    angle = 0.5 * np.arctan2(b, half_diff)
    cos, sin = np.cos(angle)[:, None], np.sin(angle)[:, None]
    upper_vector = cos * t1 + sin * t2
    lower_vector = cos * t2 - sin * t1
    # The eigenvector of an eigenvalue is the direction of the other principal curvature.
    return Curvature(normals, mid - spread, mid + spread, upper_vector, lower_vector)
