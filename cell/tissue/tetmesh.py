"""Tetrahedral meshes: structured hex-to-tet split, orientation, boundary, validation.

Orientation follows the order MuJoCo's compiler gives every 3D flex element: the right-hand
normal of face (0, 1, 2) points away from vertex 3. MuJoCo swaps vertices 1 and 2 of any element
given the other way, so meshes built here compile with ``model.flex_elem`` equal to ``tets``.

Example:
    >>> import numpy as np
    >>> g = np.stack(np.meshgrid(*[np.linspace(0, 0.1, 3)] * 3, indexing="ij"), -1)
    >>> mesh = TetMesh.from_arrays(g.reshape(-1, 3), structured_hex_tets((2, 2, 2)), "cube")
    >>> round(mesh.volume_m3, 6), len(mesh.tets)
    (0.001, 48)
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import permutations

import numpy as np

from cell.errors import MeshError

TET_FACES = np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])
"""Vertex slots of the four faces of a tet, each wound outward for a positively oriented tet."""

_TET_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]])

# Degenerate below this volume relative to the cube of the tet's longest edge (a regular tet
# has 0.118); this only separates zero volume from rounding noise, slivers are a quality matter.
_ZERO_VOLUME_RATIO = 1e-9


def _kuhn_template() -> np.ndarray:
    """(6, 4, 3) corner bits of the Kuhn split of the unit cube, each tet positively oriented.

    Tet p walks 000 -> e_p0 -> e_p0 + e_p1 -> 111; det[e_p0, e_p1, e_p2] = sign(p), and MuJoCo's
    orientation wants a negative determinant, so even permutations swap their middle vertices.
    """
    tets = []
    for p in permutations(range(3)):
        e = np.eye(3, dtype=int)[list(p)]
        walk = [np.zeros(3, int), e[0], e[0] + e[1], np.ones(3, int)]
        if np.linalg.det(e) > 0:
            walk[1], walk[2] = walk[2], walk[1]
        tets.append(walk)
    return np.array(tets)


_KUHN = _kuhn_template()


def structured_hex_tets(cells: tuple[int, int, int]) -> np.ndarray:
    """Mirrored Kuhn split of a structured grid of hexahedra into tets, 6 per cell.

    The grid has ``(n0 + 1) * (n1 + 1) * (n2 + 1)`` points in C order (index
    ``(i * (n1 + 1) + j) * (n2 + 1) + k``). Each cell's Kuhn split is reflected along every axis
    on which the cell index is odd, so neighbouring cells share face diagonals (the mesh is
    conforming) and no diagonal direction is preferred across the grid: the uniform split couples
    compression with shear and tips stacked bodies over.

    Args:
        cells: number of cells (n0, n1, n2) along the three grid axes, each >= 1.

    Returns:
        (6 * n0 * n1 * n2, 4) int point indices, positively oriented (see module docstring) when
        the map from grid indices (i, j, k) to space is right-handed; swap columns 1 and 2 for a
        left-handed map.

    Raises:
        MeshError: ``cells`` is not three integers >= 1.

    Example:
        >>> structured_hex_tets((1, 1, 1)).shape
        (6, 4)
        >>> structured_hex_tets((1, 0, 1))
        Traceback (most recent call last):
        cell.errors.MeshError: cells: must be three integers >= 1, got (1, 0, 1)
    """
    n = np.asarray(cells, dtype=int)
    if n.shape != (3,) or (n < 1).any():
        raise MeshError(None, "cells", f"must be three integers >= 1, got {cells}")
    ijk = np.stack(np.meshgrid(*(np.arange(c) for c in n), indexing="ij"), -1).reshape(-1, 3)
    parity = ijk % 2
    # Reflecting a corner bit along an odd axis mirrors the cell's split.
    bits = _KUHN[None] ^ parity[:, None, None, :]
    corner = ijk[:, None, None, :] + bits
    idx = (corner[..., 0] * (n[1] + 1) + corner[..., 1]) * (n[2] + 1) + corner[..., 2]
    # An odd number of reflections reverses orientation.
    flipped = (parity.sum(axis=1) % 2 == 1)[:, None, None]
    idx = np.where(flipped, idx[..., [0, 2, 1, 3]], idx)
    return idx.reshape(-1, 4)


def signed_volumes_m3(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Signed volume of each tet in m^3, positive in MuJoCo's orientation (module docstring).

    Example:
        >>> p = np.array([[0, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 1]], float)
        >>> float(signed_volumes_m3(p, np.array([[0, 1, 2, 3]]))[0])
        0.16666666666666666
    """
    a, b, c, d = np.moveaxis(points[tets], 1, 0)
    return np.einsum("ij,ij->i", np.cross(b - a, c - a), a - d) / 6.0


# Face f of TET_FACES is opposite vertex 3 - f; the two faces meeting at an edge (0-1, 0-2,
# 0-3, 1-2, 1-3, 2-3) are those opposite the two vertices off that edge.
_FACE_OPPOSITE = np.array([3, 2, 1, 0])
_EDGE_FACES = 3 - np.array([[2, 3], [1, 3], [1, 2], [0, 3], [0, 2], [0, 1]])


def dihedral_angles_deg(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """(M, 6) interior dihedral angles of each tet in degrees, one per edge (70.5 when regular).

    Example:
        >>> p = np.array([[0, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 1]], float)
        >>> np.round(dihedral_angles_deg(p, np.array([[0, 1, 2, 3]])), 1).tolist()
        [[90.0, 90.0, 90.0, 54.7, 54.7, 54.7]]
    """
    tri = points[tets[:, TET_FACES]]
    normal = np.cross(tri[:, :, 1] - tri[:, :, 0], tri[:, :, 2] - tri[:, :, 0])
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    # Orient by the opposite vertex so that inverted tets still give interior angles.
    opposite = points[tets[:, _FACE_OPPOSITE]]
    side = np.einsum("mfk,mfk->mf", normal, opposite - tri[:, :, 0])
    normal *= -np.sign(side)[..., None]
    cos_out = np.einsum("mek,mek->me", normal[:, _EDGE_FACES[:, 0]], normal[:, _EDGE_FACES[:, 1]])
    return 180.0 - np.degrees(np.arccos(np.clip(cos_out, -1.0, 1.0)))


def boundary_triangles(tets: np.ndarray) -> np.ndarray:
    """Faces that belong to exactly one tet, wound outward (for positively oriented tets).

    Example:
        >>> boundary_triangles(np.array([[0, 1, 2, 3]])).shape
        (4, 3)
    """
    faces, counts, first = _face_incidence(tets)
    return faces[first[counts == 1]]


def _face_incidence(tets: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All tet faces (4M, 3), and per distinct face its count and first index in the faces."""
    faces = tets[:, TET_FACES].reshape(-1, 3)
    key_cols = np.sort(faces, axis=1).astype(np.int64)
    n = int(tets.max()) + 1 if tets.size else 1
    # One int64 per face (exact for n < 2**21 points) is much faster than np.unique(axis=0).
    key = (key_cols[:, 0] * n + key_cols[:, 1]) * n + key_cols[:, 2]
    _, first, counts = np.unique(key, return_index=True, return_counts=True)
    return faces, counts, first


def validate_tet_mesh(
    points: np.ndarray,
    tets: np.ndarray,
    source: str,
    boundary: np.ndarray | None = None,
) -> None:
    """Check that a tet mesh can be simulated as a MuJoCo 3D flex; raise on the first fault.

    Args:
        points: (N, 3) vertex positions in m.
        tets: (M, 4) int vertex indices, positively oriented (module docstring).
        source: what the mesh is (file name or label), named in the error.
        boundary: optional (F, 3) surface triangles to check instead of the faces derived from
            ``tets``: they must bound a closed volume equal to the sum of the tet volumes.

    Raises:
        MeshError: ``field`` is ``"points"`` (shape, non-finite, unreferenced), ``"tets"``
            (shape, type, index out of range, zero or negative volume, a face shared by more than
            two tets) or ``"boundary"`` (not a closed, outward, consistently wound volume).

    Example:
        >>> p = np.array([[0, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 1]], float)
        >>> validate_tet_mesh(p, np.array([[0, 1, 2, 3]]), "demo")
        >>> validate_tet_mesh(p, np.array([[0, 2, 1, 3]]), "demo")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        cell.errors.MeshError: demo, tets: 1 tets have zero or negative volume, first is tet 0 ...
    """
    _checked(np.asarray(points), np.asarray(tets), source, boundary)


def _checked(
    points: np.ndarray, tets: np.ndarray, source: str, boundary: np.ndarray | None
) -> tuple[np.ndarray, float]:
    """Body of :func:`validate_tet_mesh`; returns the checked boundary and the total volume."""
    if points.ndim != 2 or points.shape[1] != 3 or len(points) == 0:
        raise MeshError(source, "points", f"must be a non-empty (N, 3) array, got {points.shape}")
    bad = ~np.isfinite(points).all(axis=1)
    if bad.any():
        raise MeshError(
            source, "points", f"{bad.sum()} points are not finite, first is point {bad.argmax()}"
        )
    if tets.ndim != 2 or tets.shape[1] != 4 or len(tets) == 0:
        raise MeshError(source, "tets", f"must be a non-empty (M, 4) array, got {tets.shape}")
    if not np.issubdtype(tets.dtype, np.integer):
        raise MeshError(source, "tets", f"must hold integer indices, got {tets.dtype}")
    out = ((tets < 0) | (tets >= len(points))).any(axis=1)
    if out.any():
        raise MeshError(
            source,
            "tets",
            f"{out.sum()} tets index outside [0, {len(points)}), first is tet {out.argmax()}",
        )
    unused = np.ones(len(points), dtype=bool)
    unused[tets.ravel()] = False
    if unused.any():
        raise MeshError(
            source,
            "points",
            f"{unused.sum()} points belong to no tet, first is point {unused.argmax()}",
        )
    volume = signed_volumes_m3(points, tets)
    x = points[tets]
    edge = x[:, _TET_EDGES[:, 1]] - x[:, _TET_EDGES[:, 0]]
    longest_sq = np.einsum("mek,mek->me", edge, edge).max(axis=1)
    flat = volume <= _ZERO_VOLUME_RATIO * longest_sq**1.5
    if flat.any():
        first = int(flat.argmax())
        raise MeshError(
            source,
            "tets",
            f"{flat.sum()} tets have zero or negative volume, first is tet {first} "
            f"({volume[first]:.3g} m^3); MuJoCo's order puts vertex 3 behind face (0, 1, 2)",
        )
    faces, counts, first_of = _face_incidence(tets)
    if (counts > 2).any():
        raise MeshError(
            source, "tets", f"{(counts > 2).sum()} faces are shared by more than two tets"
        )
    surface = faces[first_of[counts == 1]] if boundary is None else np.asarray(boundary)
    if boundary is not None and not (
            surface.ndim == 2 and surface.shape[1:] == (3,) and len(surface) > 0
            and np.issubdtype(surface.dtype, np.integer)
            and ((surface >= 0) & (surface < len(points))).all()):
        raise MeshError(source, "boundary", f"must be a non-empty (F, 3) array of point "
                        f"indices in [0, {len(points)}), got {surface.shape} {surface.dtype}")
    watertight, consistent, enclosed = _closed_surface(points, surface)
    if not (watertight and consistent and enclosed > 0.0):
        raise MeshError(
            source,
            "boundary",
            f"{len(surface)} triangles do not bound a closed volume (watertight "
            f"{watertight}, winding consistent {consistent}, volume {enclosed:.3g} m^3)",
        )
    total = float(volume.sum())
    if not np.isclose(enclosed, total, rtol=1e-9, atol=0.0):
        raise MeshError(
            source,
            "boundary",
            f"encloses {enclosed:.6g} m^3 but the tets add up to {total:.6g} m^3",
        )
    return surface, total


def _closed_surface(points: np.ndarray, triangles: np.ndarray) -> tuple[bool, bool, float]:
    """Whether ``triangles`` are watertight (every edge in two of them) and consistently
    wound (each edge run once each way), and the volume they enclose, m^3 (signed: positive
    when wound outward)."""
    triangles = np.asarray(triangles, dtype=np.int64)
    n = len(points)
    directed = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    low, high = directed.min(axis=1), directed.max(axis=1)
    _, undirected_counts = np.unique(low * n + high, return_counts=True)
    _, directed_counts = np.unique(directed[:, 0] * n + directed[:, 1], return_counts=True)
    watertight = bool((undirected_counts == 2).all())
    consistent = bool((directed_counts == 1).all())
    # The tets each triangle makes with the points' centre (fewest digits lost there): the
    # centre lies behind an outward-wound triangle, so their volumes add up to the enclosed.
    with_centre = np.vstack([points, np.mean(points, axis=0)])
    apex = np.full((len(triangles), 1), n)
    enclosed = float(signed_volumes_m3(with_centre, np.hstack([triangles, apex])).sum())
    return watertight, consistent, enclosed


@dataclass(frozen=True, eq=False)
class TetMesh:
    """A validated tetrahedral mesh, ready for ``flexcomp type="direct" dim="3"``.

    Arrays are read-only; copy them to change the mesh.

    Attributes:
        points: (N, 3) vertex positions in m.
        tets: (M, 4) int vertex indices in MuJoCo's orientation (module docstring).
        boundary: (F, 3) int surface triangles, wound outward.
        volume_m3: total volume in m^3.

    Example:
        >>> g = np.stack(np.meshgrid(*[np.linspace(0, 0.1, 3)] * 3, indexing="ij"), -1)
        >>> mesh = TetMesh.from_arrays(g.reshape(-1, 3), structured_hex_tets((2, 2, 2)), "cube")
        >>> len(mesh.boundary), round(mesh.volume_m3, 6)
        (48, 0.001)
    """

    points: np.ndarray
    tets: np.ndarray
    boundary: np.ndarray
    volume_m3: float

    @classmethod
    def from_arrays(cls, points: np.ndarray, tets: np.ndarray, source: str) -> TetMesh:
        """Validate ``points`` (m) and ``tets``, derive the boundary and volume.

        Raises:
            MeshError: see :func:`validate_tet_mesh`; ``source`` names the mesh.
        """
        points = np.array(points, dtype=float)
        tets = np.array(tets, dtype=np.int64)
        boundary, volume = _checked(points, tets, source, None)
        for array in (points, tets, boundary):
            array.setflags(write=False)
        return cls(points, tets, boundary, volume)

