"""Element quality of tet meshes (dihedral angles, radius ratios): what the geometry tests
hold the generated muscles to."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell.tissue.tetmesh import TET_FACES, dihedral_angles_deg

__all__ = ["dihedral_angles_deg", "radius_ratios"]


def radius_ratios(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """(M,) normalised radius ratio 3 r_in / r_circ of each tet: 1 when regular, 0 when flat.

    Example:
        >>> p = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
        >>> np.round(radius_ratios(p, np.array([[0, 1, 2, 3]])), 6).tolist()
        [1.0]
    """
    x = points[tets]
    a, b, c = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0], x[:, 3] - x[:, 0]
    det = np.einsum("ij,ij->i", a, np.cross(b, c))
    tri = x[:, TET_FACES]
    area = 0.5 * np.linalg.norm(
        np.cross(tri[:, :, 1] - tri[:, :, 0], tri[:, :, 2] - tri[:, :, 0]), axis=-1
    ).sum(axis=1)
    r_in = np.abs(det) / 2.0 / area
    centre = (
        (a * a).sum(1)[:, None] * np.cross(b, c)
        + (b * b).sum(1)[:, None] * np.cross(c, a)
        + (c * c).sum(1)[:, None] * np.cross(a, b)
    )
    r_circ = np.linalg.norm(centre, axis=1) / (2.0 * np.abs(det))
    return 3.0 * r_in / r_circ


@dataclass(frozen=True)
class TetQuality:
    """Worst element shape figures of a tet mesh.

    Attributes:
        min_dihedral_deg: smallest interior dihedral angle, in degrees (70.5 for a regular tet;
            slivers go towards 0).
        max_dihedral_deg: largest interior dihedral angle, in degrees (slivers go towards 180).
        min_radius_ratio: smallest 3 r_in / r_circ (1 regular, 0 degenerate).

    Example:
        >>> p = np.array([[0, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 1]], float)
        >>> round(TetQuality.of(p, np.array([[0, 1, 2, 3]])).min_dihedral_deg, 1)
        54.7
    """

    min_dihedral_deg: float
    max_dihedral_deg: float
    min_radius_ratio: float

    @classmethod
    def of(cls, points: np.ndarray, tets: np.ndarray) -> TetQuality:
        """Quality figures of ``tets`` over ``points`` (m)."""
        angles = dihedral_angles_deg(points, tets)
        return cls(
            min_dihedral_deg=float(angles.min()),
            max_dihedral_deg=float(angles.max()),
            min_radius_ratio=float(radius_ratios(points, tets).min()),
        )
