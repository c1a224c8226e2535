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

Orthotropy (``sheet_over_normal`` != 1): springs get ``1 + (k - 1) (u . s)**2`` times their
modulus (u the spring's direction, s the sheets'), and k is solved with (alpha, beta) so that the
affine lattice has the material's El along the fibres, E_s / E_n = ``sheet_over_normal`` and
sqrt(E_s E_n) = Et (:func:`sheet_factor`). A transversely isotropic material gets k = 1 and the
calibration above unchanged.

This module holds no MuJoCo: the muscles (:mod:`cell.tissue.massspring`) and the specimen
tests (:mod:`cell.diagnosis.specimen.solve`) share it.
"""

from __future__ import annotations

import copy
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
# Bracket of log(k), the sheet factor, searched by the orthotropic calibration.
_LOG_SHEET_BOUND = math.log(10.0)


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


def sheet_gain(sheet_factor: float, sheet_sq: np.ndarray) -> np.ndarray:
    """Factor on the modulus of springs at squared cosine ``sheet_sq`` to the sheets:
    ``1 + (k - 1) (u . s)**2``, 1 along the fibres and the sheets' normal, k along the sheets
    (:attr:`~cell.tissue.material.MassSpringMaterial.sheet_over_normal`)."""
    return 1.0 + (sheet_factor - 1.0) * sheet_sq


def _fibre_frame(fibre: np.ndarray, sheet: np.ndarray | None = None) -> np.ndarray:
    """(3, 3) rows: the unit fibre direction and two unit vectors across it, the first along
    ``sheet`` (made orthogonal to the fibres) where one is given."""
    a = np.asarray(fibre, dtype=float) / np.linalg.norm(fibre)
    if sheet is None:
        helper = np.eye(3)[int(np.argmin(np.abs(a)))]
        t = np.cross(a, helper)
    else:
        t = np.asarray(sheet, dtype=float) - (np.asarray(sheet, dtype=float) @ a) * a
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
        fibre: np.ndarray, oblique: float = 0.0, sheet: np.ndarray | None = None
    ) -> None:
        d = points[edges[:, 1]] - points[edges[:, 0]]
        u = d / np.linalg.norm(d, axis=1, keepdims=True) @ _fibre_frame(fibre, sheet).T
        self.cos_sq = u[:, 0] ** 2
        self.sheet_sq = u[:, 1] ** 2
        self.quartic = u[:, _VOIGT[:, 0]] * u[:, _VOIGT[:, 1]]
        self.edge_volume_m3 = edge_volume_m3
        self.volume_m3 = float(edge_volume_m3.sum()) / len(_TET_EDGES)
        self._set_oblique(oblique)

    def _set_oblique(self, oblique: float) -> None:
        self.oblique_gain = oblique_gain(oblique, self.cos_sq)
        # :meth:`_log_anisotropy` at the ends of the calibration's bracket, by (log ratio,
        # sheet factor): every calibration on this lattice starts there.
        self._bracket_ends: dict[tuple[float, float], float] = {}

    def with_oblique(self, oblique: float) -> AffineLattice:
        """This lattice with the oblique springs' factor ``oblique``: its geometry, the most
        of its cost, kept."""
        lattice = copy.copy(self)
        lattice._set_oblique(oblique)
        return lattice

    def axial_moduli(self, el_pa: float, et_pa: float,
                     sheet_factor: float = 1.0) -> tuple[float, float, float]:
        """Young's moduli (Pa) of the lattice along the fibres, the sheets (the frame's
        second axis) and their normal, Eq. 10 springs times the sheet gain."""
        # K l**2 = ||E u|| sum(V), so C = sum(||E u|| sum(V) u u u u) / V.
        weight = (directional_modulus(el_pa, et_pa, self.cos_sq) * self.oblique_gain
                  * self.edge_volume_m3)
        if sheet_factor != 1.0:
            weight = weight * sheet_gain(sheet_factor, self.sheet_sq)
        stiffness = (self.quartic * weight[:, None]).T @ self.quartic / self.volume_m3
        compliance = np.linalg.inv(stiffness)
        return (float(1.0 / compliance[0, 0]), float(1.0 / compliance[1, 1]),
                float(1.0 / compliance[2, 2]))

    def moduli(self, el_pa: float, et_pa: float,
               sheet_factor: float = 1.0) -> tuple[float, float]:
        """Young's moduli (Pa) of the lattice along and across the fibres, Eq. 10 springs:
        across, the mean of the two transverse moduli (their geometric mean, the material's
        Et, for an orthotropic lattice: ``sheet_factor`` != 1)."""
        el, es, en = self.axial_moduli(el_pa, et_pa, sheet_factor)
        return el, float(0.5 * (es + en) if sheet_factor == 1.0 else math.sqrt(es * en))

    def calibrated(self, el_pa: float, et_pa: float,
                   sheet_factor: float = 1.0) -> tuple[float, float]:
        """Eq. 10 moduli (Pa) for which the lattice's moduli are ``el_pa`` and ``et_pa``,
        its springs' sheet factor ``sheet_factor``."""
        target = math.log(el_pa / et_pa)

        def mismatch(log_ratio: float) -> float:
            return self._log_anisotropy(log_ratio, sheet_factor) - target

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
        scale = et_pa / self.moduli(ratio, 1.0, sheet_factor)[1]
        return ratio * scale, scale

    def _log_anisotropy(self, log_ratio: float, sheet_factor: float) -> float:
        """log(El / Et) of the lattice whose Eq. 10 springs have El / Et = exp(``log_ratio``)."""
        key = (log_ratio, sheet_factor)
        if key in self._bracket_ends:
            return self._bracket_ends[key]
        el, et = self.moduli(math.exp(log_ratio), 1.0, sheet_factor)
        value = math.log(el / et)
        if abs(log_ratio) == _LOG_RATIO_BOUND:
            if len(self._bracket_ends) > 4096:  # an orthotropic fit's many sheet factors
                self._bracket_ends.clear()
            self._bracket_ends[key] = value
        return value

    def sheet_calibrated(self, el_pa: float, et_pa: float, sheet_over_normal: float) -> float:
        """The sheet factor k for which the lattice, calibrated to ``el_pa`` and ``et_pa``
        (:meth:`calibrated`), has E_s / E_n = ``sheet_over_normal``.

        Raises:
            MaterialError: ``sheet_over_normal`` beyond what the lattice's springs can give.
        """
        target = math.log(sheet_over_normal)

        def mismatch(log_factor: float) -> float:
            factor = math.exp(log_factor)
            _, es, en = self.axial_moduli(*self.calibrated(el_pa, et_pa, factor), factor)
            return math.log(es / en) - target

        lo, hi = mismatch(-_LOG_SHEET_BOUND), mismatch(_LOG_SHEET_BOUND)
        if lo > 0 or hi < 0:
            raise MaterialError(
                None, "sheet_over_normal",
                f"E_s/E_n = {sheet_over_normal:.4g} is outside what this mesh's springs can give "
                f"({math.exp(lo + target):.3g} to {math.exp(hi + target):.3g})")
        return math.exp(brentq(mismatch, -_LOG_SHEET_BOUND, _LOG_SHEET_BOUND, xtol=1e-10))

    def calibration_factors(self, material: MassSpringMaterial,
                            sheet_factor: float = 1.0) -> tuple[float, float]:
        """:func:`~cell.tissue.lattice.calibration_factors` of ``material`` on this
        lattice."""
        el = material.longitudinal.small_strain_modulus_pa
        et = material.transverse.small_strain_modulus_pa
        el_in, et_in = self.calibrated(el, et, sheet_factor)
        return el_in / el, et_in / et

    def sheet_factor(self, material: MassSpringMaterial) -> float:
        """:func:`~cell.tissue.lattice.sheet_factor` of ``material`` on this lattice."""
        if not material.orthotropic:
            return 1.0
        return self.sheet_calibrated(material.longitudinal.small_strain_modulus_pa,
                                     material.transverse.small_strain_modulus_pa,
                                     material.sheet_over_normal)


def calibration_factors(
    points: np.ndarray,
    edges: np.ndarray,
    edge_volume_m3: np.ndarray,
    material: MassSpringMaterial,
    along: np.ndarray | Sequence[float],
    sheet_along: np.ndarray | Sequence[float] | None = None,
    sheet_factor: float = 1.0,
) -> tuple[float, float]:
    """(alpha, beta): the factors on El and Et for which the affine lattice of Eq. 10 springs
    has the material's small-strain moduli along and across fibres lying ``along``; with
    ``sheet_factor`` (:func:`sheet_factor`) its springs' sheet gain for sheets ``sheet_along``.

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
    return affine_lattice(points, edges, edge_volume_m3, material, along,
                          sheet_along).calibration_factors(material, sheet_factor)


def affine_lattice(points: np.ndarray, edges: np.ndarray, edge_volume_m3: np.ndarray,
                   material: MassSpringMaterial, along: np.ndarray | Sequence[float],
                   sheet_along: np.ndarray | Sequence[float] | None) -> AffineLattice:
    """The :class:`AffineLattice` that calibrates ``material`` with fibres ``along`` and sheets
    ``sheet_along``: it depends on the material's ``oblique`` and ``orthotropic`` alone."""
    # A transversely isotropic material keeps the frame across its fibres it always had.
    orthotropic = sheet_along is not None and material.orthotropic
    sheet = np.asarray(sheet_along, dtype=float) if orthotropic else None
    return AffineLattice(points, edges, edge_volume_m3, np.asarray(along, dtype=float),
                         material.oblique, sheet)


def sheet_factor(
    points: np.ndarray,
    edges: np.ndarray,
    edge_volume_m3: np.ndarray,
    material: MassSpringMaterial,
    along: np.ndarray | Sequence[float],
    sheet_along: np.ndarray | Sequence[float],
) -> float:
    """k of the springs' sheet gain (:func:`sheet_gain`) for which the lattice, fibres
    ``along`` and sheets ``sheet_along``, has the material's E_s / E_n in tension; exactly 1
    for a transversely isotropic material.

    Raises:
        MaterialError: ``sheet_over_normal`` (or ``longitudinal``) beyond the lattice's reach.
    """
    return affine_lattice(points, edges, edge_volume_m3, material, along,
                          sheet_along).sheet_factor(material)


def calibrated_law(
    points: np.ndarray,
    edges: np.ndarray,
    edge_volume_m3: np.ndarray,
    material: MassSpringMaterial,
    along: np.ndarray | Sequence[float],
    sheet_along: np.ndarray | Sequence[float] | None = None,
) -> tuple[SpringLaw, tuple[float, float], tuple[float, float], float]:
    """``material``'s spring law on this lattice, its (alpha, beta) in tension and in
    compression, each pair of curves calibrated (:func:`calibration_factors`) for fibres lying
    ``along``, and its sheet factor (:func:`sheet_factor`, for sheets ``sheet_along``, the
    material's own by default; one k for both: it is set in tension).

    Raises:
        MaterialError: ``longitudinal`` when the lattice cannot give an anisotropy,
            ``sheet_over_normal`` when it cannot give the orthotropy.
    """
    sheet = material.sheet_direction if sheet_along is None else sheet_along
    factor = sheet_factor(points, edges, edge_volume_m3, material, along, sheet)
    tension = calibration_factors(points, edges, edge_volume_m3, material, along, sheet, factor)
    compression = (tension if material.symmetric else
                   calibration_factors(points, edges, edge_volume_m3, material.in_compression(),
                                       along, sheet, factor))
    return SpringLaw.of(material, tension, compression), tension, compression, factor
