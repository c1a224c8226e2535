"""How the tissue bench times its runs (:func:`time_runs`): the largest stable step of each run,
a warm-up at the step it runs at, then timed repetitions interleaved across the runs of one
size (:func:`~cell.bench.timing.best_step_times`), with the numpy peer beside them; and what
the bench runs and for how long (:class:`TissueBenchParams`).

Usage::

    entries = time_runs({"meat": tissue_run(bench_scenario(default_meat(), 0.05, "implicit"))},
                        TissueBenchParams.quick())
    entries["meat"]["us_per_node_step"]
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from cell.bench.stability import largest_stable_timestep_s, quiet_mujoco, survives
from cell.bench.timing import StepTime, TimingJob, best_step_times
from cell.bench.tissue_peers import NumpyMassSpring
from cell.errors import DivergenceError
from cell.sim.simulation import TissueSimulation

# The runtime refuses steps above 0.9 times the springs' stable step; the bench runs there too.
_RUN_SAFETY = 0.9


@dataclass(frozen=True)
class TissueBenchParams:
    """What the bench runs and how long.

    Attributes:
        cell_sizes_m: muscle mesh cell sizes
            (:class:`~cell.tissue.shape.MuscleShape`); 0.05, 0.028 and 0.0165 m give 240,
            990 and 3944 nodes.
        realtime_cell_size_m: mesh of the real-time targets (0.021 m: 2070 nodes); ``None``
            skips them.
        max_timestep_s: cap of the stable step search, s.
        stability_steps: steps of each trial run of the stable step search.
        stability_tolerance: relative width at which the search stops.
        warmup_steps: steps before timing (the muscles settle on the table).
        timing_steps: steps per timed repetition at the smallest size; larger meshes run
            proportionally fewer, at least ``min_timing_steps``.
        min_timing_steps: fewest steps per timed repetition.
        repetitions: timed repetitions, interleaved across the runs of a size; the best
            counts.
        block_side_m: edge of the tension test cube, m.
        block_strain: displacement of its top face over its height.
        reference_cells: cells per edge of the three fine meshes of the tension test whose
            forces are extrapolated to the reference
            (:func:`~cell.bench.tissue_accuracy.extrapolated_force_n`).

    Example:
        >>> TissueBenchParams.quick().cell_sizes_m
        (0.05,)
    """

    cell_sizes_m: tuple[float, ...] = (0.05, 0.028, 0.0165)
    realtime_cell_size_m: float | None = 0.021
    max_timestep_s: float = 0.01
    stability_steps: int = 300
    stability_tolerance: float = 0.05
    warmup_steps: int = 100
    timing_steps: int = 400
    min_timing_steps: int = 30
    repetitions: int = 3
    block_side_m: float = 0.1
    block_strain: float = 0.1
    reference_cells: tuple[int, int, int] = (8, 12, 16)

    @classmethod
    def quick(cls) -> TissueBenchParams:
        """The smallest mesh only, short runs, a coarse reference: a smoke test."""
        return cls(cell_sizes_m=(0.05,), realtime_cell_size_m=None, stability_steps=60,
                   stability_tolerance=0.25, warmup_steps=20, timing_steps=40,
                   min_timing_steps=10, reference_cells=(3, 4, 6))


def _prepared(run: TissueSimulation, params: TissueBenchParams) -> tuple[dict[str, Any], TimingJob]:
    """Stable step search of ``run``, then a warm-up at 0.9 times the stable step; returns
    the entry so far and the timing job, which starts from the warmed-up state."""
    formula = run.tissue.stable_timestep_s(safety=1.0)
    with quiet_mujoco():
        stable, capped = largest_stable_timestep_s(
            lambda h: survives(run, h, params.stability_steps),
            formula if formula is not None else params.max_timestep_s / 2.0,
            params.max_timestep_s, params.stability_tolerance)
    # The runtime refuses an explicit step above 0.9 times the springs' own stable step; the
    # implicit step runs at the scenario's.
    timestep = (run.scenario.simulation.timestep_s if run.tissue.implicit
                else _RUN_SAFETY * min(stable, formula or math.inf))
    run.model.opt.timestep = timestep
    run.reset()
    run.step(params.warmup_steps)
    warm = mujoco.MjData(run.model)
    mujoco.mj_copyData(warm, run.model, run.data)
    nodes = run.scene.node_count
    steps = timing_steps(params, nodes)
    entry = {"nodes": nodes, "stable_timestep_s": stable, "stable_timestep_capped": capped,
             "formula_timestep_s": formula, "run_timestep_s": timestep, "timed_steps": steps}
    return entry, TimingJob(run.step, lambda: run.reset(warm), steps)


def _timed(entry: dict[str, Any], timing: StepTime) -> dict[str, Any]:
    """``entry`` with its timing figures."""
    return {**entry,
            "us_per_node_step": timing.wall_s / entry["nodes"] * 1e6,
            "cpu_us_per_node_step": timing.cpu_s / entry["nodes"] * 1e6,
            "real_time_factor": entry["run_timestep_s"] / timing.wall_s}


def _checked(run: TissueSimulation, entry: dict[str, Any]) -> dict[str, Any]:
    """``entry`` once the state its timing left is known to be data, with the MuJoCo
    warnings that do not make it wrong (such as an under-converged solve) but still tell."""
    try:
        run.check_divergence()
    except DivergenceError as error:
        raise DivergenceError(error.time_s, f"timing run at {entry['run_timestep_s']:.3g} s: "
                                            f"{error.reason}") from error
    warnings = {mujoco.mjtWarning(i).name: int(stat.number)
                for i, stat in enumerate(run.data.warning) if stat.number > 0}
    return {**entry, "mujoco_warnings": warnings}


def timing_steps(params: TissueBenchParams, nodes: int) -> int:
    """Steps per timed repetition: about the same wall time per repetition at every size."""
    smallest = 240
    return max(params.min_timing_steps, round(params.timing_steps * smallest / nodes))


def time_runs(runs: dict[str, TissueSimulation], params: TissueBenchParams,
               numpy_peer_of: str | None = None) -> dict[str, dict[str, Any]]:
    """Stable step, warm-up and interleaved timing of every run, and of the numpy peer of the
    run ``numpy_peer_of`` (at that run's step) under the key ``numpy_mass_spring``."""
    prepared = {key: _prepared(run, params) for key, run in runs.items()}
    jobs = {key: job for key, (_, job) in prepared.items()}
    entries = {key: entry for key, (entry, _) in prepared.items()}
    peer = None
    if numpy_peer_of is not None:
        peer = NumpyMassSpring(runs[numpy_peer_of])
        timestep = entries[numpy_peer_of]["run_timestep_s"]
        peer.step(params.warmup_steps, timestep)
        nodes = runs[numpy_peer_of].scene.node_count
        steps = timing_steps(params, nodes)
        entries["numpy_mass_spring"] = {
            "label": "plain numpy mass-spring (semi-implicit Euler, linear springs, clamp "
                     "table)", "nodes": nodes, "run_timestep_s": timestep,
            "timed_steps": steps}
        jobs["numpy_mass_spring"] = TimingJob(lambda n: peer.step(n, timestep), peer.reset,
                                              steps)
    timings = dict(zip(jobs, best_step_times(list(jobs.values()), params.repetitions),
                       strict=True))
    if peer is not None and not np.isfinite(peer.position).all():
        raise DivergenceError(0.0, "the numpy peer diverged")
    return {key: _checked(runs[key], _timed(entry, timings[key])) if key in runs
            else _timed(entry, timings[key]) for key, entry in entries.items()}
