"""One spring of the mass-spring material: its force law and its history, in numba.

The law is shared by the muscles' kernel (:mod:`cell.tissue.massspring`) and the specimen tests
(:mod:`cell.rheology.specimen`), so that a material fitted to measured tests is the material the
muscles run. It works in the spring's strain x = l / l0 - 1 and returns its *stress* s, the tension
over ``K0 l0`` where ``K0 = sum(V) / l0**2`` is the spring's geometric gain (Eq. 10 without the
modulus): ``tension = K0 * l0 * s``.

- Elastic stress (Eq. 10 with secant moduli): ``s_e = w ||E(x_e) u|| x_e / (1 + k x)``, El and
  Et the material's curves at the elastic strain x_e (:class:`~cell.tissue.curves.ModulusCurve`),
  its compression curves while x_e < 0; k is the material's ``geometric_compensation``
  (:data:`LATTICE_STIFFENING` cancels the lattice's own geometric stiffening) and w =
  ``1 + oblique 4 c**2 (1 - c**2)`` weighs springs oblique to the fibres.
- Plasticity: x_e = x - p with p the spring's plastic strain; it flows when the elastic strain
  leaves ``[-y, y]`` around the back strain ``H p``, H = h / (1 - h) for the hardening ratio h
  (linear kinematic hardening: the tangent past yield is h times the elastic one).
- Quasi-linear viscoelasticity: ``s = g_inf s_e + sum_k q_k`` with each ``q_k`` relaxing at
  ``tau_k`` and loaded by ``g_k ds_e``; the update is exact when s_e is linear in time over a
  step, so steps need not be short against ``tau_k``.

The history of E springs is an (E, 2 + K) array, one row per spring: plastic strain, last
elastic stress, then the K relaxation states. Everything starts at rest (zeros).

Example:
    >>> from cell.tissue.material import MassSpringMaterial
    >>> law = SpringLaw.of(MassSpringMaterial.isotropic(3e4, relaxation_weights=(0.5,),
    ...                                                 relaxation_times_s=(1.0,)))
    >>> history = law.history(1)
    >>> stress, _ = spring_stress(0.1, 1.0, law.curves, law.params, history, 0, 0.0, True)
    >>> round(stress)  # instantaneous: the elastic 3e4 * 0.1
    3000
    >>> stress, _ = spring_stress(0.1, 1.0, law.curves, law.params, history, 0, 100.0, True)
    >>> round(stress)  # relaxed to g_inf = 0.5
    1500
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from cell.tissue.curves import ModulusCurve
from cell.tissue.material import MassSpringMaterial

# The mirrored Kuhn lattice's geometric stiffening: linear springs give a uniaxial nominal
# secant modulus of about E (1 + 0.28 strain); a compensation of 0.33 makes it E within 0.3% over
# strains -0.3 to 0.25 (tests/test_specimen.py).
LATTICE_STIFFENING = 0.33
# Layout of SpringLaw.params.
_YIELD, _BACK, _GEOMETRY, _OBLIQUE, _G_INF, _TERMS = range(6)
# Layout of a history row.
_PLASTIC, _LAST = 0, 1
_STATES = 2


def pack_curve(curve: ModulusCurve, scale: float) -> np.ndarray:
    """(13,) a curve for :func:`secant_modulus`, its moduli times ``scale``: the polynomial's
    stress coefficients, the x bounds, the stresses and moduli at the bounds, the exponent."""
    bounds = np.array([curve.r_min, curve.r_max])
    return np.concatenate(
        [
            scale * curve.stress_coefficients()[1:],
            bounds - 1.0,
            scale * curve.stress_pa(bounds),
            scale * curve.modulus_pa(bounds),
            [curve.exponent],
        ]
    )


@njit(cache=True, fastmath=False)
def secant_modulus(x: float, curve: np.ndarray) -> float:
    """sigma(1 + x) / x, Pa, for a curve packed by :func:`pack_curve` (x = r - 1)."""
    if x > curve[7]:
        return (curve[9] + curve[11] * (x - curve[7])) / x
    if x < curve[6]:
        return (curve[8] + curve[10] * (x - curve[6])) / x
    exponent = curve[12]
    if exponent > 0.0:
        reach = exponent * abs(x)
        return curve[0] if reach == 0.0 else curve[0] * math.expm1(reach) / reach
    value = curve[5]
    for k in range(4, -1, -1):
        value = value * x + curve[k]
    return value


@njit(cache=True, fastmath=False)
def spring_stress(
    x: float,
    cos_sq: float,
    curves: np.ndarray,
    params: np.ndarray,
    history: np.ndarray,
    row: int,
    timestep_s: float,
    commit: bool,
) -> tuple[float, float]:
    """Stress of spring ``row`` at strain ``x`` after ``timestep_s`` since its last committed
    state, Pa, and its secant directional modulus ``||E u||`` (Pa) for dashpots.

    ``commit`` stores the new state in ``history``; without it the call is a trial (a solver's
    iterate) and leaves the history as it was.
    """
    plastic = history[row, _PLASTIC]
    yield_strain = params[_YIELD]
    if yield_strain > 0.0:
        back = params[_BACK]
        over = x - plastic - back * plastic
        if over > yield_strain:
            plastic += (over - yield_strain) / (1.0 + back)
        elif over < -yield_strain:
            plastic += (over + yield_strain) / (1.0 + back)
    elastic = x - plastic
    first = 2 if elastic < 0.0 else 0  # the compression curves follow the tension ones
    el = secant_modulus(elastic, curves[first])
    et = secant_modulus(elastic, curves[first + 1])
    modulus = math.sqrt(et * et + (el * el - et * et) * cos_sq) * (
        1.0 + params[_OBLIQUE] * 4.0 * cos_sq * (1.0 - cos_sq))
    # The lattice stiffens with its whole deformation, plastic part included.
    stress = modulus * elastic / (1.0 + params[_GEOMETRY] * x)
    terms = int(params[_TERMS])
    if terms > 0:
        change = stress - history[row, _LAST]
        total = params[_G_INF] * stress
        for k in range(terms):
            weight = params[_TERMS + 1 + k]
            tau = params[_TERMS + 1 + terms + k]
            ratio = timestep_s / tau
            decay = math.exp(-ratio)
            load = 1.0 if ratio == 0.0 else -math.expm1(-ratio) / ratio
            state = decay * history[row, _STATES + k] + weight * load * change
            total += state
            if commit:
                history[row, _STATES + k] = state
        if commit:
            history[row, _LAST] = stress
        stress = total
    if commit:
        history[row, _PLASTIC] = plastic
    return stress, modulus


@dataclass(frozen=True, eq=False)
class SpringLaw:
    """A material packed for :func:`spring_stress`.

    Attributes:
        curves: (4, 13) El and Et in tension, then in compression (:func:`pack_curve`), times
            their calibration factors.
        params: yield strain, back-strain factor H, geometric compensation, oblique factor,
            g_inf, K, g_1..g_K, tau_1..tau_K (s).

    Example:
        >>> SpringLaw.of(MassSpringMaterial()).params[:6].tolist()
        [0.0, 0.0, 0.0, 0.0, 1.0, 0.0]
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
        curves = np.stack([pack_curve(material.longitudinal, calibration[0]),
                           pack_curve(material.transverse, calibration[1]),
                           pack_curve(squeezed.longitudinal, compression_calibration[0]),
                           pack_curve(squeezed.transverse, compression_calibration[1])])
        weights = np.asarray(material.relaxation_weights, dtype=float)
        back = material.hardening / (1.0 - material.hardening)
        params = np.concatenate([
            [material.yield_strain, back, material.geometric_compensation, material.oblique,
             1.0 - weights.sum(), len(weights)],
            weights,
            np.asarray(material.relaxation_times_s, dtype=float),
        ])
        return cls(curves, params)

    @property
    def has_history(self) -> bool:
        """Whether a spring's stress depends on more than its current strain."""
        return bool(self.params[_YIELD] > 0.0 or self.params[_TERMS] > 0)

    def history(self, springs: int) -> np.ndarray:
        """A history at rest for ``springs`` springs."""
        return np.zeros((springs, _STATES + int(self.params[_TERMS])))
