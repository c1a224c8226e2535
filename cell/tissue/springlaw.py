"""The mass-spring material's law and every compiled kernel that runs it, in numba.

The law, :func:`spring_stress` (described with its parameters at
:class:`~cell.tissue.packedlaw.SpringLaw`), serves the muscles' kernel (:func:`muscle_forces`,
for :mod:`cell.tissue.massspring`) and the specimen's (:func:`homogeneous_stress`, for
:mod:`cell.diagnosis.specimen.solve`): a material fitted to measured tests is the one the muscles
run.

They share this file with the layouts of the packed arrays they read (the ``CURVE_``,
``PARAM_``, ``HISTORY_``, ``TANGENT_`` columns): numba's on-disk cache checks only the source
file of the kernel it loads, not those of the functions it calls or the constants it reads
(``tests/tissue/test_kernel_cache.py``); the implicit step's kernels (:mod:`cell.tissue.implicit`)
read the tangent columns too. The law is inlined into its callers (``inline="always"``),
cheaper per spring than a call; its slope is its own analytic derivative. The example of
:mod:`cell.tissue.packedlaw` packs a material and runs :func:`spring_stress`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Columns of a packed curve (:func:`~cell.tissue.packedlaw.pack_curve`): the secant modulus's
#: polynomial in x = r - 1, coefficients from the constant term up to ``CURVE_DEGREE``; at the
#: polynomial's low bound, and one column on at its high bound, x and the stress and modulus
#: there (the straight continuation past the bound); the exponential curve's exponent (0: none).
CURVE_COEFFICIENTS, CURVE_DEGREE = 0, 5
CURVE_X_LOW, CURVE_STRESS_LOW, CURVE_MODULUS_LOW = 6, 8, 10
CURVE_EXPONENT, CURVE_COLUMNS = 12, 13
#: Rows of the packed curves: El, Et in tension, then the same in compression.
CURVE_LONGITUDINAL, CURVE_TRANSVERSE, CURVE_COMPRESSION = 0, 1, 2
#: Columns of the packed parameters (:class:`~cell.tissue.packedlaw.SpringLaw`): yield strain,
#: back-strain factor H, geometric compensation, oblique factor in tension and in compression,
#: g_inf, relaxation strain slope c and reference strain x_r, the number K of relaxation
#: terms; then the K weights g_k and the K times tau_k (s) from ``PARAM_WEIGHTS`` on.
(PARAM_YIELD, PARAM_BACK, PARAM_GEOMETRY, PARAM_OBLIQUE, PARAM_OBLIQUE_COMPRESSION,
 PARAM_G_INF, PARAM_STRAIN_SLOPE, PARAM_REFERENCE_STRAIN, PARAM_TERMS, PARAM_WEIGHTS) = range(10)
#: Columns of a spring's history row: plastic strain, last relaxing stress r, then the K
#: relaxation states from ``HISTORY_STATES`` on.
HISTORY_PLASTIC, HISTORY_LAST, HISTORY_STATES = 0, 1, 2
#: Columns of a spring's tangent row (:func:`muscle_forces` writes it for the implicit step):
#: its unit direction (three columns), its tangent stiffness dT/dl (N/m), its tension over its
#: length (N/m), its dashpot (N s/m), the length (m) and the tension (N) at the law's last run.
TANGENT_DIRECTION, TANGENT_STIFFNESS, TANGENT_TENSION_PER_LENGTH, TANGENT_DASHPOT = 0, 3, 4, 5
TANGENT_LAW_LENGTH, TANGENT_LAW_TENSION, TANGENT_COLUMNS = 6, 7, 8
# The specimen's Newton solve: iterations, relative tolerance, finite-difference probe.
_NEWTON_ITERATIONS = 30
_NEWTON_TOLERANCE = 1e-8
_PROBE = 1e-7


@njit(cache=True, fastmath=False, inline="always")
def secant_modulus(x: float, curves: np.ndarray, row: int, with_slope: bool
                   ) -> tuple[float, float]:
    """sigma(1 + x) / x, Pa, for the curve in row ``row`` of ``curves``, packed by
    :func:`~cell.tissue.packedlaw.pack_curve` (x = r - 1), and with ``with_slope`` its
    derivative in x, Pa (the right one at x = 0; else 0, for callers with no use for it).

    The row is indexed, not sliced: a slice of a runtime row is a new array whose reference
    count the kernel's inner loop would update for every spring.
    """
    side = (1 if x > curves[row, CURVE_X_LOW + 1]
            else 0 if x < curves[row, CURVE_X_LOW] else -1)
    if side >= 0:  # past a bound of the polynomial: the straight continuation
        bound = curves[row, CURVE_X_LOW + side]
        stress = curves[row, CURVE_STRESS_LOW + side]
        modulus = curves[row, CURVE_MODULUS_LOW + side]
        value = (stress + modulus * (x - bound)) / x
        return value, (modulus * bound - stress) / (x * x) if with_slope else 0.0
    exponent = curves[row, CURVE_EXPONENT]
    if exponent > 0.0:
        reach = exponent * abs(x)
        if reach == 0.0:
            value = curves[row, CURVE_COEFFICIENTS]
        else:
            grown = math.expm1(reach)
            value = curves[row, CURVE_COEFFICIENTS] * grown / reach
        if not with_slope:
            return value, 0.0
        # d/dy of expm1(y) / y, by its series where the closed form cancels.
        slope = (0.5 + reach * (1.0 / 3.0 + reach / 8.0) if reach < 1e-4
                 else ((grown + 1.0) * reach - grown) / (reach * reach))
        sign = -1.0 if x < 0.0 else 1.0
        return value, curves[row, CURVE_COEFFICIENTS] * sign * exponent * slope
    value = curves[row, CURVE_COEFFICIENTS + CURVE_DEGREE]
    slope = 0.0  # Horner's rule for the derivative alongside; dropped unused once inlined
    for power in range(CURVE_DEGREE - 1, -1, -1):
        slope = slope * x + value
        value = value * x + curves[row, CURVE_COEFFICIENTS + power]
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
    plastic = history[row, HISTORY_PLASTIC]
    yield_strain = params[PARAM_YIELD]
    flow = 0.0  # d plastic / dx
    if yield_strain > 0.0:
        back = params[PARAM_BACK]
        over = x - plastic - back * plastic
        if over > yield_strain:
            plastic += (over - yield_strain) / (1.0 + back)
            flow = 1.0 / (1.0 + back)
        elif over < -yield_strain:
            plastic += (over + yield_strain) / (1.0 + back)
            flow = 1.0 / (1.0 + back)
    elastic = x - plastic
    squeezed = elastic < 0.0
    first = CURVE_COMPRESSION if squeezed else 0
    el, el_slope = secant_modulus(elastic, curves, first + CURVE_LONGITUDINAL, with_slope)
    et, et_slope = secant_modulus(elastic, curves, first + CURVE_TRANSVERSE, with_slope)
    oblique = params[PARAM_OBLIQUE_COMPRESSION] if squeezed else params[PARAM_OBLIQUE]
    weight = 1.0 + oblique * 4.0 * cos_sq * (1.0 - cos_sq)
    root = math.sqrt(et * et + (el * el - et * et) * cos_sq)
    modulus = root * weight
    # The lattice stiffens with its whole deformation, plastic part included.
    stress = modulus * elastic / (1.0 + params[PARAM_GEOMETRY] * x)
    slope = 0.0
    if with_slope:
        stiffening = 1.0 / (1.0 + params[PARAM_GEOMETRY] * x)
        modulus_slope = weight * (et * et_slope + (el * el_slope - et * et_slope) * cos_sq) / root
        slope = ((modulus_slope * elastic + modulus) * (1.0 - flow) * stiffening
                 - stress * params[PARAM_GEOMETRY] * stiffening)
    terms = int(params[PARAM_TERMS])
    if terms > 0:
        relaxing_share = 1.0 - params[PARAM_G_INF]
        free_share = 1.0 + params[PARAM_STRAIN_SLOPE] * (abs(x) - params[PARAM_REFERENCE_STRAIN])
        share = min(max(free_share, 0.0), 1.0 / max(relaxing_share, 1e-12))
        share_slope = (0.0 if share != free_share
                       else -params[PARAM_STRAIN_SLOPE] if x < 0.0 else params[PARAM_STRAIN_SLOPE])
        relaxing = share * stress
        relaxing_slope = share_slope * stress + share * slope
        change = relaxing - history[row, HISTORY_LAST]
        total = stress - relaxing_share * relaxing
        slope -= relaxing_share * relaxing_slope
        for k in range(terms):
            term_weight = params[PARAM_WEIGHTS + k]
            tau = params[PARAM_WEIGHTS + terms + k]
            ratio = timestep_s / tau
            decay = math.exp(-ratio)
            load = 1.0 if ratio == 0.0 else -math.expm1(-ratio) / ratio
            state = decay * history[row, HISTORY_STATES + k] + term_weight * load * change
            total += state
            slope += term_weight * load * relaxing_slope
            if commit:
                history[row, HISTORY_STATES + k] = state
        if commit:
            history[row, HISTORY_LAST] = relaxing
        stress = total
    if commit:
        history[row, HISTORY_PLASTIC] = plastic
    return stress, modulus, slope


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
    step needs (:mod:`cell.tissue.implicit`; the ``TANGENT_`` columns, dT/dl the law's
    derivative over the step from :func:`spring_stress`). Unless ``refresh_law``
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
            elastic = tangent[e, TANGENT_LAW_TENSION] + tangent[e, TANGENT_STIFFNESS] * (
                length - tangent[e, TANGENT_LAW_LENGTH])
            dashpot = tangent[e, TANGENT_DASHPOT]
        else:
            strain = length / rest_length[e] - 1.0
            # Two inlined calls, each with a constant flag, and numpy's error model (no
            # zero-division checks, which kept the slope's divisions alive): one call with
            # the runtime flag, or Python's error model, made the explicit step's kernel
            # markedly slower.
            if linearise:
                stress, modulus, slope = spring_stress(strain, cos_sq[e], curves, params,
                                                       history, e, timestep_s, True, True)
            else:
                stress, modulus, slope = spring_stress(strain, cos_sq[e], curves, params,
                                                       history, e, timestep_s, True, False)
            elastic = gain[e] * rest_length[e] * stress
            dashpot = gain[e] * modulus * damping_s
            if linearise:
                tangent[e, TANGENT_STIFFNESS] = gain[e] * slope
                tangent[e, TANGENT_DASHPOT] = dashpot
                tangent[e, TANGENT_LAW_LENGTH] = length
                tangent[e, TANGENT_LAW_TENSION] = elastic
        # Positive when stretched or stretching: pulls i towards j and j towards i.
        tension = elastic + dashpot * rate
        if linearise:
            tangent[e, TANGENT_DIRECTION] = ux
            tangent[e, TANGENT_DIRECTION + 1] = uy
            tangent[e, TANGENT_DIRECTION + 2] = uz
            tangent[e, TANGENT_TENSION_PER_LENGTH] = elastic / length
        if dofadr[i] >= 0:
            qfrc[dofadr[i]] += tension * ux
            qfrc[dofadr[i] + 1] += tension * uy
            qfrc[dofadr[i] + 2] += tension * uz
        if dofadr[j] >= 0:
            qfrc[dofadr[j]] -= tension * ux
            qfrc[dofadr[j] + 1] -= tension * uy
            qfrc[dofadr[j] + 2] -= tension * uz


@njit(cache=True, fastmath=False)
def _kirchhoff(gradient: np.ndarray, directions: np.ndarray, weights: np.ndarray,
               cos_sq: np.ndarray, curves: np.ndarray, params: np.ndarray, history: np.ndarray,
               timestep_s: float, commit: bool, out: np.ndarray) -> bool:
    """Kirchhoff stress (xx, yy, zz, xz; Pa) under the deformation gradient ``gradient``
    (F_xx, F_yy, F_zz, F_xz; the other entries 0); False once a spring has collapsed."""
    out[:] = 0.0
    for j in range(directions.shape[0]):
        dx, dy, dz = directions[j, 0], directions[j, 1], directions[j, 2]
        vx = gradient[0] * dx + gradient[3] * dz
        vy = gradient[1] * dy
        vz = gradient[2] * dz
        length = math.sqrt(vx * vx + vy * vy + vz * vz)
        if not length > 0.0:
            return False
        stress, _, _ = spring_stress(length - 1.0, cos_sq[j], curves, params, history, j,
                                     timestep_s, commit)
        scale = weights[j] * stress / length
        out[0] += scale * vx * vx
        out[1] += scale * vy * vy
        out[2] += scale * vz * vz
        out[3] += scale * vx * vz
    return True


@njit(cache=True, fastmath=False)
def _jacobian(gradient: np.ndarray, tau: np.ndarray, free: np.ndarray, directions: np.ndarray,
              weights: np.ndarray, cos_sq: np.ndarray, curves: np.ndarray, params: np.ndarray,
              history: np.ndarray, timestep_s: float, jacobian: np.ndarray) -> bool:
    """Forward differences of the free faces' stresses in the free components."""
    trial = np.empty(4)
    probe = np.empty(4)
    for i in range(free.shape[0]):
        trial[:] = gradient
        trial[free[i]] += _PROBE
        if not _kirchhoff(trial, directions, weights, cos_sq, curves, params, history,
                          timestep_s, False, probe):
            return False
        for r in range(free.shape[0]):
            jacobian[r, i] = (probe[free[r]] - tau[free[r]]) / _PROBE
    return True


@njit(cache=True, fastmath=False)
def homogeneous_stress(time_s: np.ndarray, path: np.ndarray, free: np.ndarray,
                       directions: np.ndarray, weights: np.ndarray, cos_sq: np.ndarray,
                       curves: np.ndarray, params: np.ndarray, history: np.ndarray,
                       tau_out: np.ndarray, gradient_out: np.ndarray) -> int:
    """The specimen's kernel (:mod:`cell.diagnosis.specimen.solve`): the homogeneous lattice
    along ``path`` ((n, 4): F - I's xx, yy, zz, xz per sample), the components in ``free``
    solved for zero Kirchhoff stress in the same components (Newton's method, its Jacobian kept
    until it stops converging fast, with a backtracking line search: the plastic law has
    kinks); the Kirchhoff stress (xx, yy, zz, xz; Pa) into ``tau_out``, F (xx, yy, zz, xz) into
    ``gradient_out``; returns the first sample without an equilibrium, or -1."""
    unit = np.array([1.0, 1.0, 1.0, 0.0])
    held = np.ones(4, dtype=np.bool_)
    held[free] = False
    state = unit + path[0]
    previous = state.copy()
    trial, tau, probe = np.empty(4), np.empty(4), np.empty(4)
    jacobian = np.zeros((free.shape[0], free.shape[0]))
    fresh = False
    # Stresses below this are round-off: the small-strain modulus times a micro-strain.
    floor = 1e-6 * max(abs(curves[CURVE_LONGITUDINAL, CURVE_COEFFICIENTS]),
                       abs(curves[CURVE_TRANSVERSE, CURVE_COEFFICIENTS]))
    for k in range(time_s.shape[0]):
        timestep = time_s[k] - time_s[k - 1] if k > 0 else 0.0
        # Predict the free components by extrapolating along the held one that moved most.
        lead = np.argmax(np.abs(path[k - 1] - path[k - 2]) * held) if k > 1 else 0
        moved = path[k - 1, lead] - path[k - 2, lead] if k > 1 else 0.0
        slope = (path[k, lead] - path[k - 1, lead]) / moved if moved != 0.0 else np.inf
        step_back = state - previous
        previous[:] = state
        if abs(slope) <= 4.0:
            state += slope * step_back
        state[held] = unit[held] + path[k][held]
        if not _kirchhoff(state, directions, weights, cos_sq, curves, params, history,
                          timestep, False, tau):
            return k
        norm = np.abs(tau[free]).sum()
        converged = False
        for _ in range(_NEWTON_ITERATIONS):
            if norm <= _NEWTON_TOLERANCE * max(np.abs(tau[held]).sum() + norm, floor):
                converged = True
                break
            if (k == 0 and not fresh) or (not fresh and jacobian[0, 0] == 0.0):
                fresh = _jacobian(state, tau, free, directions, weights, cos_sq, curves,
                                  params, history, timestep, jacobian)
                if not fresh:
                    return k
            step = np.linalg.solve(jacobian, tau[free])
            length = 1.0
            improved = False
            for _ in range(8):
                trial[:] = state
                for i in range(free.shape[0]):
                    trial[free[i]] -= length * step[i]
                if _kirchhoff(trial, directions, weights, cos_sq, curves, params, history,
                              timestep, False, probe):
                    trial_norm = np.abs(probe[free]).sum()
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
                fresh = _jacobian(state, tau, free, directions, weights, cos_sq, curves,
                                  params, history, timestep, jacobian)
                if not fresh:
                    return k
        if not converged:
            return k
        _kirchhoff(state, directions, weights, cos_sq, curves, params, history, timestep,
                   True, tau)
        tau_out[k] = tau
        gradient_out[k] = state
    return -1
