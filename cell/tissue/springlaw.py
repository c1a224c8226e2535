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

Every compiled kernel that calls :func:`spring_stress` lives in this module: the muscles'
(:func:`muscle_forces`) and the specimen's (:func:`uniaxial_stress`). numba's on-disk cache
(``cache=True``) checks only the source file of the kernel it loads, not those of the functions
it calls, so a kernel in another module would keep running the law it was compiled with after
the law changed; here one file's stamp covers the law and all its callers
(``tests/test_kernel_cache.py``).
The law is inlined into its callers (numba's ``inline="always"``): called, it left the
muscles' kernel at 49 ns a spring, inlined 38 (990 nodes, the default meat, with a second
trial call for the tangent's finite difference; the tangent is now the law's own analytic
derivative, checked against central differences in ``tests/test_springlaw.py``).

Example:
    >>> from cell.tissue.material import MassSpringMaterial
    >>> law = SpringLaw.of(MassSpringMaterial.isotropic(3e4, relaxation_weights=(0.5,),
    ...                                                 relaxation_times_s=(1.0,)))
    >>> history = law.history(1)
    >>> stress, _, _ = spring_stress(0.1, 1.0, law.curves, law.params, history, 0, 0.0, True)
    >>> round(stress)  # instantaneous: the elastic 3e4 * 0.1
    3000
    >>> stress, _, _ = spring_stress(0.1, 1.0, law.curves, law.params, history, 0, 100.0, True)
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
(_YIELD, _BACK, _GEOMETRY, _OBLIQUE, _OBLIQUE_COMPRESSION, _G_INF, _STRAIN_SLOPE,
 _REFERENCE_STRAIN, _TERMS) = range(9)
# Layout of a history row.
_PLASTIC, _LAST = 0, 1
_STATES = 2
# The specimen's Newton solve: iterations, relative tolerance, finite-difference probe.
_NEWTON_ITERATIONS = 30
_NEWTON_TOLERANCE = 1e-8
_PROBE = 1e-7


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


@njit(cache=True, fastmath=False, inline="always")
def secant_modulus(x: float, curves: np.ndarray, row: int, with_slope: bool
                   ) -> tuple[float, float]:
    """sigma(1 + x) / x, Pa, for the curve in row ``row`` of ``curves``, packed by
    :func:`pack_curve` (x = r - 1), and with ``with_slope`` its derivative in x, Pa (the
    right one at x = 0; else 0, for callers that have no use for it).

    The row is indexed, not sliced: a slice of a runtime row is a new array whose reference
    count the kernel's inner loop would update for every spring.
    """
    if x > curves[row, 7]:
        value = (curves[row, 9] + curves[row, 11] * (x - curves[row, 7])) / x
        if not with_slope:
            return value, 0.0
        return value, (curves[row, 11] * curves[row, 7] - curves[row, 9]) / (x * x)
    if x < curves[row, 6]:
        value = (curves[row, 8] + curves[row, 10] * (x - curves[row, 6])) / x
        if not with_slope:
            return value, 0.0
        return value, (curves[row, 10] * curves[row, 6] - curves[row, 8]) / (x * x)
    exponent = curves[row, 12]
    if exponent > 0.0:
        reach = exponent * abs(x)
        if reach == 0.0:
            value = curves[row, 0]
        else:
            grown = math.expm1(reach)
            value = curves[row, 0] * grown / reach
        if not with_slope:
            return value, 0.0
        # d/dy of expm1(y) / y, by its series where the closed form cancels.
        slope = (0.5 + reach * (1.0 / 3.0 + reach / 8.0) if reach < 1e-4
                 else ((grown + 1.0) * reach - grown) / (reach * reach))
        return value, curves[row, 0] * (-exponent if x < 0.0 else exponent) * slope
    value = curves[row, 5]
    slope = 0.0  # Horner's rule for the derivative alongside; dropped unused once inlined
    for k in range(4, -1, -1):
        slope = slope * x + value
        value = value * x + curves[row, k]
    return value, slope if with_slope else 0.0


@njit(cache=True, fastmath=False, inline="always")
def spring_stress(
    x: float,
    cos_sq: float,
    curves: np.ndarray,
    params: np.ndarray,
    history: np.ndarray,
    row: int,
    timestep_s: float,
    commit: bool,
    with_slope: bool = False,
) -> tuple[float, float, float]:
    """Stress of spring ``row`` at strain ``x`` after ``timestep_s`` since its last committed
    state, Pa; its secant directional modulus ``||E u||`` (Pa) for dashpots; and with
    ``with_slope`` the stress's derivative in x over that step (Pa: the tangent an implicit
    step needs, relaxation's instant share and plastic flow included; else 0).

    ``commit`` stores the new state in ``history``; without it the call is a trial (a solver's
    iterate) and leaves the history as it was.
    """
    plastic = history[row, _PLASTIC]
    yield_strain = params[_YIELD]
    flow = 0.0  # d plastic / dx
    if yield_strain > 0.0:
        back = params[_BACK]
        over = x - plastic - back * plastic
        if over > yield_strain:
            plastic += (over - yield_strain) / (1.0 + back)
            flow = 1.0 / (1.0 + back)
        elif over < -yield_strain:
            plastic += (over + yield_strain) / (1.0 + back)
            flow = 1.0 / (1.0 + back)
    elastic = x - plastic
    squeezed = elastic < 0.0
    first = 2 if squeezed else 0  # the compression curves follow the tension ones
    el, el_slope = secant_modulus(elastic, curves, first, with_slope)
    et, et_slope = secant_modulus(elastic, curves, first + 1, with_slope)
    oblique = params[_OBLIQUE_COMPRESSION] if squeezed else params[_OBLIQUE]
    weight = 1.0 + oblique * 4.0 * cos_sq * (1.0 - cos_sq)
    root = math.sqrt(et * et + (el * el - et * et) * cos_sq)
    modulus = root * weight
    # The lattice stiffens with its whole deformation, plastic part included.
    stress = modulus * elastic / (1.0 + params[_GEOMETRY] * x)
    slope = 0.0
    if with_slope:
        stiffening = 1.0 / (1.0 + params[_GEOMETRY] * x)
        modulus_slope = weight * (et * et_slope + (el * el_slope - et * et_slope) * cos_sq) / root
        slope = ((modulus_slope * elastic + modulus) * (1.0 - flow) * stiffening
                 - stress * params[_GEOMETRY] * stiffening)
    terms = int(params[_TERMS])
    if terms > 0:
        relaxing_share = 1.0 - params[_G_INF]
        free_share = 1.0 + params[_STRAIN_SLOPE] * (abs(x) - params[_REFERENCE_STRAIN])
        share = min(max(free_share, 0.0), 1.0 / max(relaxing_share, 1e-12))
        share_slope = (0.0 if share != free_share
                       else -params[_STRAIN_SLOPE] if x < 0.0 else params[_STRAIN_SLOPE])
        relaxing = share * stress
        relaxing_slope = share_slope * stress + share * slope
        change = relaxing - history[row, _LAST]
        total = stress - relaxing_share * relaxing
        slope -= relaxing_share * relaxing_slope
        for k in range(terms):
            term_weight = params[_TERMS + 1 + k]
            tau = params[_TERMS + 1 + terms + k]
            ratio = timestep_s / tau
            decay = math.exp(-ratio)
            load = 1.0 if ratio == 0.0 else -math.expm1(-ratio) / ratio
            state = decay * history[row, _STATES + k] + term_weight * load * change
            total += state
            slope += term_weight * load * relaxing_slope
            if commit:
                history[row, _STATES + k] = state
        if commit:
            history[row, _LAST] = relaxing
        stress = total
    if commit:
        history[row, _PLASTIC] = plastic
    return stress, modulus, slope


@dataclass(frozen=True, eq=False)
class SpringLaw:
    """A material packed for :func:`spring_stress`.

    Attributes:
        curves: (4, 13) El and Et in tension, then in compression (:func:`pack_curve`), times
            their calibration factors.
        params: yield strain, back-strain factor H, geometric compensation, oblique factor
            in tension and in compression, g_inf, relaxation strain slope c and reference
            strain x_r, K, g_1..g_K, tau_1..tau_K (s).

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
        curves = np.stack([pack_curve(material.longitudinal, calibration[0]),
                           pack_curve(material.transverse, calibration[1]),
                           pack_curve(squeezed.longitudinal, compression_calibration[0]),
                           pack_curve(squeezed.transverse, compression_calibration[1])])
        weights = np.asarray(material.relaxation_weights, dtype=float)
        back = material.hardening / (1.0 - material.hardening)
        params = np.concatenate([
            [material.yield_strain, back, material.geometric_compensation, material.oblique,
             squeezed.oblique, 1.0 - weights.sum(), material.relaxation_strain_slope,
             material.relaxation_reference_strain, len(weights)],
            weights,
            np.asarray(material.relaxation_times_s, dtype=float),
        ])
        return cls(curves, params)

    def history(self, springs: int) -> np.ndarray:
        """A history at rest for ``springs`` springs."""
        return np.zeros((springs, _STATES + int(self.params[_TERMS])))


@njit(cache=True, fastmath=False, inline="always")
def _vertex_state(qpos: np.ndarray, qvel: np.ndarray, qfrc: np.ndarray, qposadr: np.ndarray,
                  dofadr: np.ndarray, rest_position: np.ndarray, position: np.ndarray,
                  velocity: np.ndarray) -> None:
    """Every vertex's position and velocity into ``position`` and ``velocity`` (pinned ones
    at rest), and its dofs' entries of ``qfrc`` cleared."""
    for i in range(position.shape[0]):
        a = qposadr[i]
        v = dofadr[i]
        for k in range(3):
            if a < 0:
                position[i, k] = rest_position[i, k]
                velocity[i, k] = 0.0
            else:
                position[i, k] = rest_position[i, k] + qpos[a + k]
                velocity[i, k] = qvel[v + k]
                qfrc[v + k] = 0.0


@njit(cache=True, fastmath=False, error_model="numpy")
def muscle_forces(qpos: np.ndarray, qvel: np.ndarray, qfrc: np.ndarray, qposadr: np.ndarray,
                  dofadr: np.ndarray, rest_position: np.ndarray, edges: np.ndarray,
                  rest_length: np.ndarray, gain: np.ndarray, cos_sq: np.ndarray,
                  curves: np.ndarray, params: np.ndarray, history: np.ndarray,
                  timestep_s: float, damping_s: float, position: np.ndarray,
                  velocity: np.ndarray, tangent: np.ndarray, refresh_law: bool) -> None:
    """The muscles' kernel (:class:`~cell.tissue.massspring.MassSpringModel`): clear the
    vertex dofs of ``qfrc``, add every spring-damper's force to them and advance the springs'
    history by ``timestep_s``.

    With a ``tangent`` of one row per spring (else of none), each row gets what an implicit
    step needs (:mod:`cell.tissue.implicit`): the spring's unit direction, its tangent
    stiffness along it dT/dl (N/m, the law's derivative over the step from
    :func:`spring_stress`), its tension over its length (N/m), its dashpot (N s/m), then
    the length (m) and the tension (N) at which the law last ran. Unless ``refresh_law``
    the law does not run: each spring's tension is that last tension plus dT/dl times the
    change of length since (the law's tangent line), and the history stays where it was;
    the next refresh advances it by its ``timestep_s``, the time since the last one.
    """
    linearise = tangent.shape[0] == edges.shape[0]
    frozen = linearise and not refresh_law
    _vertex_state(qpos, qvel, qfrc, qposadr, dofadr, rest_position, position, velocity)
    for e in range(edges.shape[0]):
        i = edges[e, 0]
        j = edges[e, 1]
        dx = position[j, 0] - position[i, 0]
        dy = position[j, 1] - position[i, 1]
        dz = position[j, 2] - position[i, 2]
        length = math.sqrt(dx * dx + dy * dy + dz * dz)
        if length == 0.0:  # a collapsed edge has no direction to push along
            continue
        ux, uy, uz = dx / length, dy / length, dz / length
        rate = ((velocity[j, 0] - velocity[i, 0]) * ux + (velocity[j, 1] - velocity[i, 1]) * uy
                + (velocity[j, 2] - velocity[i, 2]) * uz)
        if frozen:
            elastic = tangent[e, 7] + tangent[e, 3] * (length - tangent[e, 6])
            dashpot = tangent[e, 5]
        else:
            strain = length / rest_length[e] - 1.0
            # Two inlined calls, each with a constant flag, and numpy's error model (no
            # zero-division checks, which kept the slope's divisions alive): one call with
            # the runtime flag, or Python's error model, left the explicit step's kernel at
            # 41 ns a spring instead of 30.
            if linearise:
                stress, modulus, slope = spring_stress(strain, cos_sq[e], curves, params,
                                                       history, e, timestep_s, True, True)
            else:
                stress, modulus, slope = spring_stress(strain, cos_sq[e], curves, params,
                                                       history, e, timestep_s, True, False)
            elastic = gain[e] * rest_length[e] * stress
            dashpot = gain[e] * modulus * damping_s
            if linearise:
                tangent[e, 3] = gain[e] * slope
                tangent[e, 5] = dashpot
                tangent[e, 6] = length
                tangent[e, 7] = elastic
        # Positive when stretched or stretching: pulls i towards j and j towards i.
        tension = elastic + dashpot * rate
        if linearise:
            tangent[e, 0], tangent[e, 1], tangent[e, 2] = ux, uy, uz
            tangent[e, 4] = elastic / length
        if dofadr[i] >= 0:
            qfrc[dofadr[i]] += tension * ux
            qfrc[dofadr[i] + 1] += tension * uy
            qfrc[dofadr[i] + 2] += tension * uz
        if dofadr[j] >= 0:
            qfrc[dofadr[j]] -= tension * ux
            qfrc[dofadr[j] + 1] -= tension * uy
            qfrc[dofadr[j] + 2] -= tension * uz


@njit(cache=True, fastmath=False)
def _kirchhoff(state: np.ndarray, stretch: float, directions: np.ndarray, weights: np.ndarray,
               cos_sq: np.ndarray, curves: np.ndarray, params: np.ndarray, history: np.ndarray,
               timestep_s: float, commit: bool, out: np.ndarray) -> bool:
    """Kirchhoff stress (xx, yy, xz, zz; Pa) of F(a, b, c; stretch); False once a spring has
    collapsed."""
    a, b, c = state[0], state[1], state[2]
    out[:] = 0.0
    for j in range(directions.shape[0]):
        dx, dy, dz = directions[j, 0], directions[j, 1], directions[j, 2]
        vx = a * dx + c * dz
        vy = b * dy
        vz = stretch * dz
        length = math.sqrt(vx * vx + vy * vy + vz * vz)
        if not length > 0.0:
            return False
        stress, _, _ = spring_stress(length - 1.0, cos_sq[j], curves, params, history, j,
                                  timestep_s, commit)
        scale = weights[j] * stress / length
        out[0] += scale * vx * vx
        out[1] += scale * vy * vy
        out[2] += scale * vx * vz
        out[3] += scale * vz * vz
    return True


@njit(cache=True, fastmath=False)
def _jacobian(state: np.ndarray, tau: np.ndarray, stretch: float, directions: np.ndarray,
              weights: np.ndarray, cos_sq: np.ndarray, curves: np.ndarray, params: np.ndarray,
              history: np.ndarray, timestep_s: float, jacobian: np.ndarray) -> bool:
    """Forward differences of the lateral stresses in (a, b, c) into ``jacobian``."""
    trial = np.empty(3)
    probe = np.empty(4)
    for i in range(3):
        trial[:] = state
        trial[i] += _PROBE
        if not _kirchhoff(trial, stretch, directions, weights, cos_sq, curves, params, history,
                          timestep_s, False, probe):
            return False
        for r in range(3):
            jacobian[r, i] = (probe[r] - tau[r]) / _PROBE
    return True


@njit(cache=True, fastmath=False)
def uniaxial_stress(time_s: np.ndarray, strain: np.ndarray, directions: np.ndarray,
              weights: np.ndarray, cos_sq: np.ndarray, curves: np.ndarray, params: np.ndarray,
              history: np.ndarray, stress_out: np.ndarray, lateral_out: np.ndarray) -> int:
    """The specimen's kernel (:mod:`cell.rheology.specimen`): nominal axial stress (Pa) of the
    homogeneous lattice at every sample into ``stress_out``; returns the index of the first
    sample without an equilibrium, or -1.

    Newton's method with a Jacobian kept from sample to sample and refreshed when it stops
    converging fast, and a backtracking line search (the plastic law has kinks).
    """
    state = np.array([1.0, 1.0, 0.0])
    previous = state.copy()
    trial = np.empty(3)
    tau = np.empty(4)
    probe = np.empty(4)
    jacobian = np.zeros((3, 3))
    fresh = False
    # Stresses below this are round-off: the small-strain modulus times a micro-strain.
    floor = 1e-6 * max(abs(curves[0, 0]), abs(curves[1, 0]))
    for k in range(time_s.shape[0]):
        timestep = time_s[k] - time_s[k - 1] if k > 0 else 0.0
        stretch = 1.0 + strain[k]
        # Predict the lateral state by extrapolating along the strain from the last two.
        if k > 1 and strain[k - 1] != strain[k - 2]:
            slope = (strain[k] - strain[k - 1]) / (strain[k - 1] - strain[k - 2])
            if abs(slope) <= 4.0:
                step_back = state - previous
                previous[:] = state
                state += slope * step_back
            else:
                previous[:] = state
        else:
            previous[:] = state
        if not _kirchhoff(state, stretch, directions, weights, cos_sq, curves, params, history,
                          timestep, False, tau):
            return k
        norm = abs(tau[0]) + abs(tau[1]) + abs(tau[2])
        converged = False
        for _ in range(_NEWTON_ITERATIONS):
            if norm <= _NEWTON_TOLERANCE * max(abs(tau[3]) + norm, floor):
                converged = True
                break
            if (k == 0 and not fresh) or (not fresh and jacobian[0, 0] == 0.0):
                fresh = _jacobian(state, tau, stretch, directions, weights, cos_sq, curves,
                                  params, history, timestep, jacobian)
                if not fresh:
                    return k
            step = np.linalg.solve(jacobian, tau[:3])
            length = 1.0
            improved = False
            for _ in range(8):
                trial[:] = state - length * step
                if _kirchhoff(trial, stretch, directions, weights, cos_sq, curves, params,
                              history, timestep, False, probe):
                    trial_norm = abs(probe[0]) + abs(probe[1]) + abs(probe[2])
                    if trial_norm < norm:
                        improved = True
                        break
                length *= 0.5
            if (improved and trial_norm < 0.25 * norm) or (improved and fresh):
                state[:] = trial
                tau[:] = probe
                norm = trial_norm
                fresh = False
            elif fresh:
                return k
            else:
                fresh = _jacobian(state, tau, stretch, directions, weights, cos_sq, curves,
                                  params, history, timestep, jacobian)
                if not fresh:
                    return k
        if not converged:
            return k
        _kirchhoff(state, stretch, directions, weights, cos_sq, curves, params, history,
                   timestep, True, tau)
        stress_out[k] = tau[3] / stretch
        lateral_out[k, 0] = state[0]
        lateral_out[k, 1] = state[1]
    return -1
