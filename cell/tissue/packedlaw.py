"""The mass-spring material packed for the spring law's kernels (:mod:`cell.tissue.springlaw`).

The law works in the spring's strain x = l / l0 - 1 and returns its *stress* s, the tension
over ``K0 l0`` where ``K0 = sum(V) / l0**2`` is the spring's geometric gain (Eq. 10 without the
modulus): ``tension = K0 * l0 * s``.

- Elastic stress (Eq. 10 with secant moduli): ``s_e = w ||E(x_e) u|| x_e / (1 + k x)``, El and
  Et the material's curves at the elastic strain x_e (:class:`~cell.tissue.curves.ModulusCurve`),
  its compression curves while x_e < 0; k is the material's ``geometric_compensation``
  (:data:`LATTICE_STIFFENING` cancels the lattice's own geometric stiffening) and w =
  ``1 + oblique 4 c**2 (1 - c**2)`` weighs springs oblique to the fibres (the material's
  compression factor while x_e < 0).
- Plasticity: x_e = x - p with p the spring's plastic strain; it flows when the elastic strain
  leaves ``[-y, y]`` around the back strain ``H p``, H = h / (1 - h) for the hardening ratio h
  (linear kinematic hardening: the tangent past yield is h times the elastic one).
- Viscoelasticity: ``s = s_e - G r + sum_k q_k`` with ``G = sum g_k`` and the relaxing stress
  ``r = w(x) s_e``, each ``q_k`` relaxing at ``tau_k`` and loaded by ``g_k dr``: the response
  to a step is s_e at once and ``(1 - G w) s_e`` relaxed. With ``w = 1`` this is quasi-linear
  viscoelasticity (``s = g_inf s_e + sum_k q_k``, g_inf = 1 - G); the material's
  ``relaxation_strain_slope`` c makes the relaxed fraction depend on the strain held (plastic
  part included), ``w = 1 + c (|x| - x_r)`` (clipped to [0, 1 / G]; x_r the material's
  ``relaxation_reference_strain``, at which G relaxes): non-linear viscoelasticity, as muscle
  relaxes a smaller fraction at larger strain (c < 0). The update is exact when r is linear in
  time over a step, so steps need not be short against ``tau_k``.

The history of E springs is an (E, 2 + K) array, one row per spring: plastic strain, last
relaxing stress r, then the K relaxation states. Everything starts at rest (zeros).

Example:
    >>> from cell.tissue.springlaw import spring_stress
    >>> law = SpringLaw.of(MassSpringMaterial.isotropic(3e4, relaxation_weights=(0.5,),
    ...                                                 relaxation_times_s=(1.0,)))
    >>> history = law.history(1)
    >>> stress, _, _ = spring_stress(0.1, 1.0, law.curves, law.params, history, 0, 0.0, True)
    >>> round(stress)  # at once: the elastic 3e4 * 0.1
    3000
    >>> stress, _, _ = spring_stress(0.1, 1.0, law.curves, law.params, history, 0, 100.0, True)
    >>> round(stress)  # held: relaxed to g_inf = 0.5
    1500
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from cell.tissue.curves import ModulusCurve
from cell.tissue.material import MassSpringMaterial
from cell.tissue.springlaw import (
    CURVE_COEFFICIENTS,
    CURVE_COLUMNS,
    CURVE_COMPRESSION,
    CURVE_DEGREE,
    CURVE_EXPONENT,
    CURVE_LONGITUDINAL,
    CURVE_MODULUS_LOW,
    CURVE_STRESS_LOW,
    CURVE_TRANSVERSE,
    CURVE_X_LOW,
    HISTORY_STATES,
    PARAM_BACK,
    PARAM_G_INF,
    PARAM_GEOMETRY,
    PARAM_OBLIQUE,
    PARAM_OBLIQUE_COMPRESSION,
    PARAM_REFERENCE_STRAIN,
    PARAM_STRAIN_SLOPE,
    PARAM_TERMS,
    PARAM_WEIGHTS,
    PARAM_YIELD,
)

#: The mirrored Kuhn lattice's geometric stiffening: linear springs give a uniaxial nominal
#: secant modulus that grows with the strain; this compensation cancels it within the
#: tolerance of ``tests/diagnosis/specimen/test_solve.py`` over the strains it checks.
LATTICE_STIFFENING = 0.33


# The columns of a packed curve that are moduli (scaled): coefficients, stresses, moduli.
_SCALED = np.r_[CURVE_COEFFICIENTS:CURVE_COEFFICIENTS + CURVE_DEGREE + 1,
                CURVE_STRESS_LOW:CURVE_STRESS_LOW + 2, CURVE_MODULUS_LOW:CURVE_MODULUS_LOW + 2]


def pack_curve(curve: ModulusCurve, scale: float) -> np.ndarray:
    """(``CURVE_COLUMNS``,) a curve for :func:`~cell.tissue.springlaw.secant_modulus`, its
    moduli times ``scale``: the polynomial's stress coefficients, the x bounds, the stresses
    and moduli at the bounds, the exponent (the ``CURVE_`` columns of
    :mod:`cell.tissue.springlaw`).

    Example:
        >>> pack_curve(MassSpringMaterial().longitudinal, 2.0).shape
        (13,)
    """
    packed = _unscaled(curve).copy()
    packed[_SCALED] *= scale
    return packed


@lru_cache(maxsize=4096)
def _unscaled(curve: ModulusCurve) -> np.ndarray:
    """:func:`pack_curve` at scale 1, read-only: a fit packs the same few curves at every
    step, each time with other calibration factors."""
    bounds = np.array([curve.r_min, curve.r_max])
    packed = np.empty(CURVE_COLUMNS)
    packed[CURVE_COEFFICIENTS:CURVE_COEFFICIENTS + CURVE_DEGREE + 1] = (
        curve.stress_coefficients()[1:])
    packed[CURVE_X_LOW:CURVE_X_LOW + 2] = bounds - 1.0
    packed[CURVE_STRESS_LOW:CURVE_STRESS_LOW + 2] = curve.stress_pa(bounds)
    packed[CURVE_MODULUS_LOW:CURVE_MODULUS_LOW + 2] = curve.modulus_pa(bounds)
    packed[CURVE_EXPONENT] = curve.exponent
    packed.flags.writeable = False
    return packed


@dataclass(frozen=True, eq=False)
class SpringLaw:
    """A material packed for :func:`~cell.tissue.springlaw.spring_stress` (module docstring).

    Attributes:
        curves: (4, ``CURVE_COLUMNS``) El and Et in tension, then in compression
            (:func:`pack_curve`), times their calibration factors.
        params: yield strain, back-strain factor H, geometric compensation, oblique factor
            in tension and in compression, g_inf, relaxation strain slope c and reference
            strain x_r, K, g_1..g_K, tau_1..tau_K (s): the ``PARAM_`` columns of
            :mod:`cell.tissue.springlaw`.

    Example:
        >>> SpringLaw.of(MassSpringMaterial()).params[:9].tolist()
        [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]
    """

    curves: np.ndarray
    params: np.ndarray

    @classmethod
    def of(cls, material: MassSpringMaterial, calibration: tuple[float, float] = (1.0, 1.0),
           compression_calibration: tuple[float, float] | None = None) -> SpringLaw:
        """Pack ``material`` with its moduli times ``calibration`` (alpha, beta), its
        compression curves times ``compression_calibration`` (the same when None)."""
        squeezed = material.in_compression()
        compression_calibration = compression_calibration or calibration
        curves = np.empty((2 * CURVE_COMPRESSION, CURVE_COLUMNS))
        for first, source, factors in ((0, material, calibration),
                                       (CURVE_COMPRESSION, squeezed, compression_calibration)):
            curves[first + CURVE_LONGITUDINAL] = pack_curve(source.longitudinal, factors[0])
            curves[first + CURVE_TRANSVERSE] = pack_curve(source.transverse, factors[1])
        weights = np.asarray(material.relaxation_weights, dtype=float)
        terms = len(weights)
        params = np.empty(PARAM_WEIGHTS + 2 * terms)
        params[PARAM_YIELD] = material.yield_strain
        params[PARAM_BACK] = material.hardening / (1.0 - material.hardening)
        params[PARAM_GEOMETRY] = material.geometric_compensation
        params[PARAM_OBLIQUE] = material.oblique
        params[PARAM_OBLIQUE_COMPRESSION] = squeezed.oblique
        params[PARAM_G_INF] = 1.0 - weights.sum()
        params[PARAM_STRAIN_SLOPE] = material.relaxation_strain_slope
        params[PARAM_REFERENCE_STRAIN] = material.relaxation_reference_strain
        params[PARAM_TERMS] = terms
        params[PARAM_WEIGHTS:PARAM_WEIGHTS + terms] = weights
        params[PARAM_WEIGHTS + terms:] = np.asarray(material.relaxation_times_s, dtype=float)
        return cls(curves, params)

    def history(self, springs: int) -> np.ndarray:
        """A history at rest for ``springs`` springs."""
        return np.zeros((springs, HISTORY_STATES + int(self.params[PARAM_TERMS])))
