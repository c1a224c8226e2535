"""When a MuJoCo state is no longer data: the divergence checks that every stepping loop of the
project runs (the cell's :class:`~cell.sim.simulation.TissueSimulation`, a cut test's block in
:mod:`cell.cuttest.run`).

Example:
    >>> import mujoco
    >>> model = mujoco.MjModel.from_xml_string(
    ...     '<mujoco><worldbody><body><freejoint/><geom size="1"/></body></worldbody>'
    ...     '</mujoco>')
    >>> data = mujoco.MjData(model)
    >>> check_state(data, np.arange(6), fatal_warnings(data), 20.0, 0.0)  # at rest: nothing
"""

from __future__ import annotations

import mujoco
import numpy as np
from numba import njit

from cell.errors import DivergenceError

#: Warnings after which MuJoCo's state is no longer a solution of the model.
FATAL_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQACC,
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
)
_FATAL_INDEX = np.array([int(w) for w in FATAL_WARNINGS])


def fatal_warnings(data: mujoco.MjData) -> np.ndarray:
    """How many times each of :data:`FATAL_WARNINGS` has fired in ``data``."""
    return data.warning.number[_FATAL_INDEX]


def check_state(data: mujoco.MjData, dofs: np.ndarray, warnings_before: np.ndarray,
                max_speed_m_s: float, time_s: float) -> None:
    """Raise :class:`DivergenceError` on a fatal MuJoCo warning since ``warnings_before``
    (:func:`fatal_warnings` then), a non-finite state, or one of ``dofs`` faster than
    ``max_speed_m_s`` (m/s).

    ``time_s`` is the time the step should have reached: after a fatal warning MuJoCo
    resets the state, time included, so ``data.time`` no longer tells.
    """
    fired = fatal_warnings(data) > warnings_before
    if fired.any():
        names = [w.name for w, f in zip(FATAL_WARNINGS, fired, strict=True) if f]
        raise DivergenceError(time_s, f"MuJoCo warning {', '.join(names)}")
    finite, speed = _finite_and_fastest(data.qpos, data.qvel, dofs)
    if not finite:
        raise DivergenceError(float(data.time), "non-finite position or velocity")
    if speed > max_speed_m_s:
        raise DivergenceError(float(data.time),
                              f"tissue speed {speed:.3g} m/s above {max_speed_m_s} m/s")


@njit(cache=True)
def _finite_and_fastest(qpos: np.ndarray, qvel: np.ndarray, dofs: np.ndarray
                        ) -> tuple[bool, float]:
    """Whether every position and velocity is finite, and the largest speed of ``dofs``
    (0 without any). Compiled, one pass: it runs after every physics step."""
    for value in qpos:
        if not np.isfinite(value):
            return False, 0.0
    for value in qvel:
        if not np.isfinite(value):
            return False, 0.0
    fastest = 0.0
    for dof in dofs:
        fastest = max(fastest, abs(qvel[dof]))
    return True, fastest
