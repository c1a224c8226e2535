"""The spring lattice of a tet mesh: its edges, their volumes and the calibration of Eq. 10.

Calibration: a spring lattice is not the continuum whose moduli set its springs. The affine
(homogeneous strain) stiffness of the lattice, ``C = sum(K l0**2 u u u u) / V``, gives its
Young's moduli along and across the fibres; for the mirrored Kuhn split of cubic cells with
Eq. 8 it is ``42/31 E = 1.355 E`` (Poisson's ratio 5/31 = 0.16), and Eq. 10 compresses the
anisotropy (El/Et = 0.42 comes out as 0.55). :class:`~cell.tissue.massspring.MassSpringModel`
therefore feeds Eq. 10 with the moduli ``(alpha El, beta Et)`` for which the affine lattice of its
own mesh has the material's small-strain moduli El and Et along and across the fibres: alpha = beta
= 31/42 for isotropic cubic cells, alpha = 0.47 and beta = 0.78 for the paper's El = 0.25 MPa, Et =
0.6 MPa with fibres along a cell axis. On cells that are not cubes alpha and beta differ even for an
isotropic material: they also undo the cells' own anisotropy along and across the fibres. A
central-force lattice reaches a limited anisotropy (El/Et about 0.16 to 9 on the muscle meshes,
depending on the fibre direction); beyond it the model refuses the material. The factors are
constant over the stretch, exact while the curves keep their small-strain ratio El/Et; at large
stretch the springs off the load axis see less of the strain than the material does, so a curve
that stiffens fourfold over its range is followed within 8% (isotropic) to 16% (El != Et) at
r = 1.3, one that stiffens twofold within 5%.

This module holds no MuJoCo: the muscles (:mod:`cell.tissue.massspring`) and the specimen
tests (:mod:`cell.diagnosis.specimen.solve`) share it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.optimize import brentq

from cell.errors import MaterialError
from cell.tissue.material import MassSpringMaterial
from cell.tissue.packedlaw import SpringLaw
from cell.tissue.tetmesh import _TET_EDGES, signed_volumes_m3

# Voigt order of the symmetric index pairs of a strain.
_VOIGT = np.array([[0, 0], [1, 1], [2, 2], [1, 2], [0, 2], [0, 1]])
# Bracket of log(El / Et) searched by the calibration.
_LOG_RATIO_BOUND = math.log(1e4)


def tet_edges(points: np.ndarray, tets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique edges of a tet mesh and, per edge, the volume of the tets that share it.

    Args:
        points: (N, 3) vertex positions, m.
        tets: (M, 4) int vertex indices.

    Returns:
        ``edges`` (E, 2) int64 vertex pairs, lower index first, and ``edge_volume_m3`` (E,):
        the sum of the volumes of the tets holding each edge (their sum is 6 times the mesh
        volume: a tet has six edges).

    Example:
        >>> p = np.array([[0, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 1]], float)
        >>> edges, volume = tet_edges(p, np.array([[0, 1, 2, 3]]))
        >>> len(edges), round(float(volume.sum()), 6)
        (6, 1.0)
    """
    volume = np.abs(signed_volumes_m3(points, tets))
    pairs = np.sort(np.asarray(tets, dtype=np.int64)[:, _TET_EDGES].reshape(-1, 2), axis=1)
    key = pairs[:, 0] * len(points) + pairs[:, 1]
    _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
    return pairs[first], np.bincount(inverse, weights=np.repeat(volume, len(_TET_EDGES)))


def directional_modulus(
    el_pa: float | np.ndarray, et_pa: float | np.ndarray, cos_sq: np.ndarray
) -> np.ndarray:
    """``||E u||`` of Eq. 10 (Pa) for edges at squared cosine ``cos_sq`` to the fibres."""
    # Et**2 + (El**2 - Et**2) c**2 keeps El == Et exact: sqrt(E**2) == E in IEEE arithmetic.
    return np.sqrt(et_pa**2 + (el_pa**2 - et_pa**2) * cos_sq)


def oblique_gain(oblique: float, cos_sq: np.ndarray) -> np.ndarray:
    """Factor on Eq. 10's modulus of springs at squared cosine ``cos_sq`` to the fibres:
    ``1 + oblique * 4 c**2 (1 - c**2)``, 1 along and across them, ``1 + oblique`` at 45 degrees
    (:attr:`~cell.tissue.material.MassSpringMaterial.oblique`)."""
    return 1.0 + oblique * 4.0 * cos_sq * (1.0 - cos_sq)


def _fibre_frame(fibre: np.ndarray) -> np.ndarray:
    """(3, 3) rows: the unit fibre direction and two unit vectors across it."""
    a = np.asarray(fibre, dtype=float) / np.linalg.norm(fibre)
    helper = np.eye(3)[int(np.argmin(np.abs(a)))]
    t = np.cross(a, helper)
    t /= np.linalg.norm(t)
    return np.stack([a, t, np.cross(a, t)])


class AffineLattice:
    """Affine (homogeneous strain) stiffness of a spring lattice, in the fibre frame.

    Example:
        >>> p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
        >>> edges, volume = tet_edges(p, np.array([[0, 1, 2, 3]]))
        >>> AffineLattice(p, edges, volume, np.array([1.0, 0, 0])).cos_sq.shape
        (6,)
    """

    def __init__(
        self, points: np.ndarray, edges: np.ndarray, edge_volume_m3: np.ndarray,
        fibre: np.ndarray, oblique: float = 0.0
    ) -> None:
        d = points[edges[:, 1]] - points[edges[:, 0]]
        u = d / np.linalg.norm(d, axis=1, keepdims=True) @ _fibre_frame(fibre).T
        self.cos_sq = u[:, 0] ** 2
        self.oblique_gain = oblique_gain(oblique, self.cos_sq)
        self.quartic = u[:, _VOIGT[:, 0]] * u[:, _VOIGT[:, 1]]
        self.edge_volume_m3 = edge_volume_m3
        self.volume_m3 = float(edge_volume_m3.sum()) / len(_TET_EDGES)

    def moduli(self, el_pa: float, et_pa: float) -> tuple[float, float]:
        """Young's moduli (Pa) of the lattice along and across the fibres, Eq. 10 springs."""
        # K l**2 = ||E u|| sum(V), so C = sum(||E u|| sum(V) u u u u) / V.
        weight = (directional_modulus(el_pa, et_pa, self.cos_sq) * self.oblique_gain
                  * self.edge_volume_m3)
        stiffness = (self.quartic * weight[:, None]).T @ self.quartic / self.volume_m3
        compliance = np.diag(np.linalg.inv(stiffness))
        return float(1.0 / compliance[0]), float(0.5 * (1.0 / compliance[1] + 1.0 / compliance[2]))

    def calibrated(self, el_pa: float, et_pa: float) -> tuple[float, float]:
        """Eq. 10 moduli (Pa) for which the lattice's moduli are ``el_pa`` and ``et_pa``."""
        target = math.log(el_pa / et_pa)

        def mismatch(log_ratio: float) -> float:
            el, et = self.moduli(math.exp(log_ratio), 1.0)
            return math.log(el / et) - target

        lo, hi = mismatch(-_LOG_RATIO_BOUND), mismatch(_LOG_RATIO_BOUND)
        if lo > 0 or hi < 0:
            reachable = (math.exp(lo + target), math.exp(hi + target))
            raise MaterialError(
                None,
                "longitudinal",
                f"El/Et = {el_pa / et_pa:.4g} is outside what this mesh's springs can give "
                f"({reachable[0]:.3g} to {reachable[1]:.3g})",
            )
        ratio = math.exp(brentq(mismatch, -_LOG_RATIO_BOUND, _LOG_RATIO_BOUND, xtol=1e-12))
        scale = et_pa / self.moduli(ratio, 1.0)[1]
        return ratio * scale, scale


def calibration_factors(
    points: np.ndarray,
    edges: np.ndarray,
    edge_volume_m3: np.ndarray,
    material: MassSpringMaterial,
    along: np.ndarray | Sequence[float],
) -> tuple[float, float]:
    """(alpha, beta): the factors on El and Et for which the affine lattice of Eq. 10 springs
    has the material's small-strain moduli along and across fibres lying ``along``.

    Raises:
        MaterialError: ``longitudinal`` when the lattice cannot give the anisotropy.

    Example:
        >>> from cell.tissue.tetmesh import structured_hex_tets
        >>> grid = np.stack(np.meshgrid(*[np.linspace(0, 0.1, 3)] * 3, indexing="ij"), -1)
        >>> points = grid.reshape(-1, 3)
        >>> edges, volume = tet_edges(points, structured_hex_tets((2, 2, 2)))
        >>> factors = calibration_factors(points, edges, volume, MassSpringMaterial(), (1, 0, 0))
        >>> [round(f, 3) for f in factors]
        [0.738, 0.738]
    """
    lattice = AffineLattice(points, edges, edge_volume_m3, np.asarray(along, dtype=float),
                             material.oblique)
    el = material.longitudinal.small_strain_modulus_pa
    et = material.transverse.small_strain_modulus_pa
    el_in, et_in = lattice.calibrated(el, et)
    return el_in / el, et_in / et


def calibrated_law(
    points: np.ndarray,
    edges: np.ndarray,
    edge_volume_m3: np.ndarray,
    material: MassSpringMaterial,
    along: np.ndarray | Sequence[float],
) -> tuple[SpringLaw, tuple[float, float], tuple[float, float]]:
    """``material``'s spring law on this lattice and its (alpha, beta) in tension and in
    compression: each pair of curves calibrated (:func:`calibration_factors`) for fibres lying
    ``along``.

    Raises:
        MaterialError: ``longitudinal`` when the lattice cannot give an anisotropy.
    """
    tension = calibration_factors(points, edges, edge_volume_m3, material, along)
    compression = (tension if material.symmetric else
                   calibration_factors(points, edges, edge_volume_m3, material.in_compression(),
                                       along))
    return SpringLaw.of(material, tension, compression), tension, compression
