"""Element quality of tet meshes (dihedral angles, radius ratios): what the geometry tests
hold the generated muscles to."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell.tissue.tetmesh import TET_FACES

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
