"""Eq. 10 stiffness and a lattice's affine moduli, for the tests of the mass-spring lattice
(the library calibrates through :class:`cell.tissue.lattice.AffineLattice` directly)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from cell.tissue.lattice import AffineLattice, directional_modulus


def spring_stiffness(
    points: np.ndarray,
    edges: np.ndarray,
    edge_volume_m3: np.ndarray,
    el_pa: float | np.ndarray,
    et_pa: float | np.ndarray,
    fibre: np.ndarray | Sequence[float],
) -> np.ndarray:
    """Eq. 10: stiffness (N/m) of each edge spring, ``||E u|| sum(V) / l**2``.

    Args:
        points: (N, 3) vertex positions, m (the lengths and directions are taken here).
        edges: (E, 2) vertex pairs.
        edge_volume_m3: (E,) volume of the tets sharing each edge, m^3.
        el_pa: modulus along the fibres, Pa (a scalar or one per edge).
        et_pa: modulus across the fibres (Et = Er), Pa.
        fibre: fibre direction, any length.

    Returns:
        (E,) stiffness, N/m; equal to Eq. 8, ``E sum(V) / l**2``, when ``el_pa == et_pa == E``.

    Example:
        >>> p = np.array([[0, 0, 0], [0.01, 0, 0], [0, 0.01, 0]])
        >>> spring_stiffness(p, np.array([[0, 1], [0, 2]]), np.full(2, 1e-6), 2e5, 6e5, (1, 0, 0))
        array([2000., 6000.])
    """
    d = points[edges[:, 1]] - points[edges[:, 0]]
    length_sq = np.einsum("ij,ij->i", d, d)
    f = np.asarray(fibre, dtype=float)
    cos_sq = (d @ f) ** 2 / (length_sq * (f @ f))
    return directional_modulus(el_pa, et_pa, cos_sq) * edge_volume_m3 / length_sq


def lattice_moduli(
    points: np.ndarray,
    edges: np.ndarray,
    edge_volume_m3: np.ndarray,
    el_pa: float,
    et_pa: float,
    fibre: np.ndarray | Sequence[float],
) -> tuple[float, float]:
    """Young's moduli (Pa) along and across the fibres of a lattice of Eq. 10 springs.

    From the lattice's affine stiffness: every edge strained as the mesh is. Exact for a
    uniform strain of a periodic lattice; a finite block relaxes about 2% softer.

    Example:
        >>> from cell.tissue.lattice import tet_edges
        >>> from cell.tissue.tetmesh import TetMesh, structured_hex_tets
        >>> g = np.stack(np.meshgrid(*[np.linspace(0, 0.1, 5)] * 3, indexing="ij"), -1)
        >>> mesh = TetMesh.from_arrays(g.reshape(-1, 3), structured_hex_tets((4, 4, 4)), "c")
        >>> edges, volume = tet_edges(mesh.points, mesh.tets)
        >>> [round(e / 3e4, 3) for e in lattice_moduli(mesh.points, edges, volume, 3e4, 3e4,
        ...                                            (1, 0, 0))]
        [1.355, 1.355]
    """
    lattice = AffineLattice(points, edges, edge_volume_m3, np.asarray(fibre, dtype=float))
    return lattice.moduli(el_pa, et_pa)
