"""Where a step of the bare muscles spends its time, and the spring kernel against its floor.

:func:`step_profile` times the parts of :meth:`TissueSimulation.step` one by one, in the
step's own order (the springs' kernel, the binding springs, the implicit solve, then
``mj_step`` with MuJoCo's own stage timers), in microseconds per step and per node.
The spring kernel (:func:`~cell.tissue.springlaw.muscle_forces`) is timed as the step calls
it, at the steps that run the law and at those that follow its tangent line;
:func:`kernel_floor` sets it against a kernel that moves the same data per spring (both ends'
positions and velocities gathered, the implicit step's tangent row written, both ends' forces
scattered) with a linear spring in place of the law: a law step's cost above that floor is
about the law's, the floor over the bytes moved is the rate the memory access runs at.

Example:
    >>> from cell.bench.tissue_variants import bench_scenario, tissue_run
    >>> from cell.tissue.material import default_meat
    >>> run = tissue_run(bench_scenario(default_meat(), 0.05, "implicit"))
    >>> sorted(step_profile(run, steps=5)["us_per_step"])
    ['bindings', 'implicit_solve', 'mujoco', 'springs']
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from functools import partial
from typing import Any

import mujoco
import numpy as np
from numba import njit

from cell.sim.simulation import TissueSimulation

#: MuJoCo's stage timers the profile reports (``mjtTimer`` names less ``mjTIMER_``).
MUJOCO_STAGES = ("POS_KINEMATICS", "POS_INERTIA", "POS_COLLISION", "POS_MAKE", "VELOCITY",
                 "CONSTRAINT", "ADVANCE")


def step_profile(run: TissueSimulation, steps: int = 200, rounds: int = 3) -> dict[str, Any]:
    """``rounds`` rounds of ``steps`` steps of ``run`` from its present state, each part timed
    (``time.perf_counter``); the round of the least total time counts (as the bench's best
    of three): per step (us) and per node and step (us), with MuJoCo's stages from its own
    timers, and the springs' kernel against its floor (:func:`kernel_floor`). The state
    moves on as :meth:`TissueSimulation.step` would move it."""
    profiles = [_profile_round(run, steps) for _ in range(rounds)]
    profile = min(profiles, key=lambda profile: sum(profile["us_per_step"].values()))
    springs = sum(len(model.edges) for model in run.tissue.springs.values())
    kernel = profile["us_per_step"]["springs"] * 1e3 / springs
    steps = profile.pop("springs_us_per_step")
    return profile | {"kernel": {"ns_per_spring": kernel,
                                 "law_ns_per_spring": steps["law"] * 1e3 / springs,
                                 "linearised_ns_per_spring": steps["linearised"] * 1e3 / springs,
                                 **kernel_floor(run)}}


def _profile_round(run: TissueSimulation, steps: int) -> dict[str, Any]:
    tissue, model, data = run.tissue, run.model, run.data
    parts = {"springs": 0.0, "bindings": 0.0, "implicit_solve": 0.0, "mujoco": 0.0}
    # The springs' time and steps where the law ran and where they followed its tangent.
    kernel = {True: [0.0, 0], False: [0.0, 0]}
    for timer in data.timer:
        timer.duration, timer.number = 0.0, 0
    for _ in range(steps):
        law = all(springs.runs_law for springs in tissue.springs.values())
        clock = time.perf_counter()
        for springs in tissue.springs.values():
            springs.apply(data, filtered=False)
        lap = time.perf_counter()
        parts["springs"] += lap - clock
        kernel[law][0] += lap - clock
        kernel[law][1] += 1
        tissue.aponeurosis.apply_forces(data)
        clock = time.perf_counter()
        parts["bindings"] += clock - lap
        for springs in tissue.springs.values():
            springs.filter(data)
        lap = time.perf_counter()
        parts["implicit_solve"] += lap - clock
        mujoco.mj_step(model, data)
        parts["mujoco"] += time.perf_counter() - lap
    run.check_divergence()
    nodes = run.scene.node_count
    stages = {name.lower(): data.timer[int(getattr(mujoco.mjtTimer, f"mjTIMER_{name}"))]
              .duration / steps * 1e6 for name in MUJOCO_STAGES}
    per_step = {part: seconds / steps * 1e6 for part, seconds in parts.items()}
    return {"nodes": nodes, "steps": steps, "us_per_step": per_step,
            "us_per_node_step": {part: us / nodes for part, us in per_step.items()},
            "mujoco_stages_us_per_step": stages,
            "mujoco_bodies": int(model.nbody), "mujoco_dofs": int(model.nv),
            "contacts": int(data.ncon),
            "springs_us_per_step": {"law": _mean_us(*kernel[True]),
                                    "linearised": _mean_us(*kernel[False])}}


def _mean_us(seconds: float, count: int) -> float | None:
    # None (JSON null) where nothing was timed: strict JSON has no NaN.
    return seconds / count * 1e6 if count else None


def kernel_floor(run: TissueSimulation, calls: int = 500) -> dict[str, Any]:
    """The floor kernel (module docstring) on every muscle of ``run`` at its present state:
    its ns per spring (best of three rounds of ``calls``), the bytes it and the kernel (at a
    step that runs the law, and at one that follows its tangent) move per spring, and its
    rate (GB/s). The simulation is left as it was."""
    total_s, springs_count = 0.0, 0
    history_columns = 0
    for springs in run.tissue.springs.values():
        edges = springs.edges
        position, velocity = springs.vertex_state(run.data)
        forces, tangent = np.zeros_like(run.data.qfrc_applied), np.zeros((len(edges), 8))
        total_s += _best_call_s(partial(
            floor_kernel, position, velocity, forces, springs.dofadr, edges,
            springs.rest_lengths_m, springs.stiffness_n_m, tangent), calls)
        springs_count += len(edges)
        history_columns = springs.history_columns
    floor = total_s / springs_count * 1e9
    # Per spring: its two vertex indices, rest length, gain and fibre cosine (the floor: a
    # stiffness), both ends' positions and velocities, six numbers of the tangent row
    # written, both ends' three forces read and written. The law's run also reads and writes
    # the spring's history row and writes two more of the tangent row; the tangent line
    # reads four of the row instead of the gain and the cosine.
    floor_bytes = 2 * 8 + 2 * 8 + 4 * 3 * 8 + 6 * 8 + 2 * 6 * 8
    return {"springs": springs_count, "floor_ns_per_spring": floor,
            "bytes_per_spring": {"law": floor_bytes + 8 + 2 * 8 + 2 * history_columns * 8,
                                 "linearised": floor_bytes - 8 + 4 * 8,
                                 "floor": floor_bytes},
            "floor_gb_per_s": floor_bytes / floor}


def _best_call_s(call: Callable[[], object], calls: int) -> float:
    """Seconds a call of ``call`` takes, best of three rounds of ``calls``."""
    call()  # compiled and warm
    best = math.inf
    for _ in range(3):
        clock = time.perf_counter()
        for _ in range(calls):
            call()
        best = min(best, (time.perf_counter() - clock) / calls)
    return best


@njit(cache=True, fastmath=False)
def floor_kernel(position: np.ndarray, velocity: np.ndarray, qfrc: np.ndarray,
                    dofadr: np.ndarray, edges: np.ndarray, rest_length: np.ndarray,
                    stiffness: np.ndarray, tangent: np.ndarray) -> None:
    """The floor kernel: the spring kernel's data movement with Hooke's law. Its scatter
    repeats the kernel's on purpose: a helper that both call, inlined by numba or left to
    LLVM, slowed the kernel (``docs/benchmarks.md``)."""
    for e in range(edges.shape[0]):
        i = edges[e, 0]
        j = edges[e, 1]
        dx = position[j, 0] - position[i, 0]
        dy = position[j, 1] - position[i, 1]
        dz = position[j, 2] - position[i, 2]
        length = math.sqrt(dx * dx + dy * dy + dz * dz)
        if length == 0.0:
            continue
        ux, uy, uz = dx / length, dy / length, dz / length
        rate = ((velocity[j, 0] - velocity[i, 0]) * ux + (velocity[j, 1] - velocity[i, 1]) * uy
                + (velocity[j, 2] - velocity[i, 2]) * uz)
        tension = stiffness[e] * (length - rest_length[e]) + 1e-3 * rate
        tangent[e, 0], tangent[e, 1], tangent[e, 2] = ux, uy, uz
        tangent[e, 3] = tangent[e, 5] = stiffness[e]
        tangent[e, 4] = tension / length
        if dofadr[i] >= 0:
            qfrc[dofadr[i]] += tension * ux
            qfrc[dofadr[i] + 1] += tension * uy
            qfrc[dofadr[i] + 2] += tension * uz
        if dofadr[j] >= 0:
            qfrc[dofadr[j]] -= tension * ux
            qfrc[dofadr[j] + 1] -= tension * uy
            qfrc[dofadr[j] + 2] -= tension * uz
