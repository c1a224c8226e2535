"""The diagnosis of a batch of separation logs (docs/logs.md): what the simulation gets
wrong about them, why, and the world that gets it right, in the contract of the measurement
sets (baseline, causes, candidates with evidence, extended, held-out error, gain), held out
by leave-one-log-out.

A replay is an episode, so the search is kept to a few dozen of them: one replay of every
log in the lab's world (the baseline), two per log and cause with the cause's screening
magnitude one way and the other (its linearised signature: the change of every channel at
every sample), a greedy forward selection on those signatures (:mod:`cell.sim.logfit`: a
sensor's offset is a constant on its channel, in closed form), Gauss-Newton steps on the
causes selected, each confirmed by replaying the batch (Broyden's update keeps the
signatures true to the replays), a line search along the fit (:func:`_stretch`), and one
replay per log left out, in the world fitted on the others: unless those lower the held-out
error by the gain asked, the world's causes are not named (a change that fits the logs it
was fitted to but no log left out). Replays run side by side on every core, or on a Ray
cluster (:mod:`cell.sim.logreplays`).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cell.sim.logbatch import LogBatch
from cell.sim.logcauses import CAUSES, SENSOR_OFFSET, applicable, magnitudes_json
from cell.sim.logfit import (
    FORCE_CHANNELS,
    Rows,
    broyden,
    forward_selection,
    heldout,
    logged_vector,
    rmse_n,
    signature,
    solve,
)
from cell.sim.logreplays import Replayer, ReplayPool

#: The largest magnitude a Gauss-Newton step may reach (a factor of about 4.5, or 86 deg):
#: beyond it the cell is another cell, and its physics may not hold.
MAX_MAGNITUDE = 1.5
_OFFSET = SENSOR_OFFSET + ":"
#: The line search's factor on the fitted magnitudes (:func:`_stretch`) and its most replays.
STRETCH = 1.3
STRETCH_REPLAYS = 3


@dataclass(frozen=True)
class LogDiagnosisParams:
    """How the batch diagnosis searches.

    Attributes:
        workers: replays side by side on this machine (None: one per core); on a cluster
            (:func:`diagnose_logs`'s ``cluster``), its pool says how many.
        min_heldout_gain: the share by which a cause must lower the held-out RMSE (linearised
            in the selection; replayed to confirm the world causes, on the logs fitted and
            on each log left out).
        newton_steps: Gauss-Newton steps on the causes selected, a batch replay each.
        causes: the world causes screened (None: every one that applies).

    Example:
        >>> LogDiagnosisParams(workers=1).newton_steps
        2
    """

    workers: int | None = None
    min_heldout_gain: float = 0.08
    newton_steps: int = 2
    causes: tuple[str, ...] | None = None


@dataclass
class LogDiagnosis:
    """A batch's diagnosis (:meth:`to_json` gives the contract's keys).

    Attributes:
        logs: the logs' names.
        baseline_rmse_n: each log's force RMSE in the lab's world, N.
        causes: the causes named, most important first.
        candidates: every cause screened, with its linearised fit.
        extended: the magnitudes and offsets of the extended world, and its RMSE.
        heldout_rmse_n: baseline and extended RMSE of the logs left out, N.
        evidence: per named cause, the held-out RMSE with and without it.
        steps: the forward selection's steps.
        simulated: the simulated vectors of the baseline and the extended world.
        timing: replays, their wall and CPU time, and the fits' (the rest's), s.

    Example:
        >>> LogDiagnosis(["a", "b"], [2.0, 2.0], [], [], {}, {"baseline": 2.0, "extended": 1.5},
        ...              {}, [], {}, {}).gain
        0.25
    """

    logs: list[str]
    baseline_rmse_n: list[float]
    causes: list[str]
    candidates: list[dict[str, Any]]
    extended: dict[str, Any]
    heldout_rmse_n: dict[str, float]
    evidence: dict[str, dict[str, Any]]
    steps: list[dict[str, Any]]
    simulated: dict[str, np.ndarray] = field(repr=False)
    timing: dict[str, float]

    @property
    def gain(self) -> float:
        """``1 - extended / baseline`` held-out RMSE."""
        base = self.heldout_rmse_n["baseline"]
        return 1.0 - self.heldout_rmse_n["extended"] / base if base > 0 else 0.0

    def to_json(self) -> dict[str, Any]:
        """The contract (docs/diagnosis.md) with the logs' evidence."""
        return {"logs": self.logs,
                "baseline": {"model": "the logs' scenarios as the lab believes them",
                             "params": {}, "rmse_N": self.baseline_rmse_n,
                             "heldout_rmse_N": self.heldout_rmse_n["baseline"]},
                "causes": self.causes, "candidates": self.candidates,
                "extended": {**self.extended,
                             "heldout_rmse_N": self.heldout_rmse_n["extended"]},
                "evidence": self.evidence, "steps": self.steps, "gain": self.gain,
                "timing": self.timing}


def diagnose_logs(batch: LogBatch, params: LogDiagnosisParams | None = None,
                  cluster: ReplayPool | None = None) -> LogDiagnosis:
    """Diagnose ``batch`` (module docstring), its replays on ``params.workers`` processes
    here, or on ``cluster`` (an entered :class:`cell.scale.pool.RunPool` on a Ray cluster,
    whose ``Workers`` then say how many run at a time).

    Raises:
        DivergenceError: the lab's own world blew up in a replay.
        PoolError: a replay on ``cluster`` gave no result (its worker or node died).
    """
    params = params or LogDiagnosisParams()
    measured, rows = logged_vector(batch.logs)
    names = [c for c in applicable(batch.scenarios[0])
             if params.causes is None or c in params.causes]
    workers = params.workers or os.cpu_count() or 1
    started, cpu_started = time.perf_counter(), time.process_time()
    jobs = len(batch.logs) * (2 * len(names) + 1)
    with Replayer(batch, min(workers, jobs), cluster) as replayer:
        base, blocks = _screen(replayer, measured, names)
        residual = measured - base
        blocks.update({_OFFSET + ch: rows.resting_offset(residual, ch) for ch in FORCE_CHANNELS})
        fixed = frozenset(_OFFSET + ch for ch in FORCE_CHANNELS)
        steps = forward_selection(residual, blocks, rows, params.min_heldout_gain, fixed)
        chosen = [step.added for step in steps[1:]]
        world = [c for c in chosen if c in CAUSES]
        offsets = {c: blocks[c] for c in chosen if c.startswith(_OFFSET)}
        fit = _newton(replayer, measured, base, blocks, world, offsets, params)
        without = heldout(residual, offsets, rows, _fixed(offsets))
        left = (_heldout_replays(replayer, measured, rows, fit, world, offsets)
                if world and fit["confirmed"] else without)
        if world and (not fit["confirmed"] or rmse_n(left)
                      > (1.0 - params.min_heldout_gain) * rmse_n(without)):
            # Only the offsets stand when the world's causes do not lower the error of the logs
            # they were fitted to, or do but not of each log left out (the change does not
            # carry from one separation to the next): then they are named as dropped.
            dropped = ({"causes": world, "heldout_rmse_N": rmse_n(left),
                        "without_N": rmse_n(without)} if fit["confirmed"] else None)
            world, left = [], without
            fit = _newton(replayer, measured, base, blocks, world, offsets, params)
            if dropped is not None:
                fit["dropped"] = dropped
    causes = world + ([SENSOR_OFFSET] if offsets else [])
    baseline = [rmse_n(residual[rows.log == i]) for i in range(len(batch.logs))]
    heldout_rmse = {"baseline": rmse_n(residual), "extended": rmse_n(left)}
    offset_fit = {c.removeprefix(_OFFSET): _offset_n(offsets[c], rows, fit["offsets"][c])
                  for c in offsets}
    extended = {"model": "the logs' scenarios with the causes' changes",
                "params": {**magnitudes_json(fit["magnitudes"]),
                           **({SENSOR_OFFSET: offset_fit} if offset_fit else {})},
                "rmse_N": rmse_n(fit["left"]), "confirmed": fit["confirmed"],
                **({"dropped": fit["dropped"]} if "dropped" in fit else {})}
    return LogDiagnosis(
        [log.name for log in batch.logs], baseline, causes,
        _candidates(residual, blocks, rows, chosen), extended, heldout_rmse,
        _evidence(residual, blocks, rows, chosen, left),
        [{"added": s.added, "information": s.information, "heldout_rmse_N": s.heldout_rmse_n}
         for s in steps], {"baseline": base, "extended": fit["simulated"],
                           "measured": measured},
        _timing(replayer, started, cpu_started))


def _timing(replayer: Replayer, started: float, cpu_started: float) -> dict[str, float]:
    """Where the time went: the replays' and the rest's (the fits', in this process), wall
    and CPU, s."""
    wall = time.perf_counter() - started
    cpu = time.process_time() - cpu_started - (replayer.cpu_s if replayer.in_process else 0.0)
    return {"replays": replayer.count, "replay_wall_s": replayer.wall_s,
            "fit_s": wall - replayer.wall_s, "total_s": wall, "replay_cpu_s": replayer.cpu_s,
            "fit_cpu_s": cpu}


def _screen(replayer: Replayer, measured: np.ndarray, names: list[str]
            ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The baseline's simulated vector and each cause's signature (:func:`signature`), from
    one batch replay in the lab's world and one each way of every cause's screening step."""
    screens = [(c, side * CAUSES[c].step) for c in names for side in (1.0, -1.0)]
    base, *screened = replayer.batches([{}] + [{c: m} for c, m in screens])
    if base is None:
        from cell.errors import DivergenceError

        raise DivergenceError(0.0, "a replay of the lab's own world blew up")
    blocks: dict[str, np.ndarray] = {}
    for k, c in enumerate(names):
        sides = [(m, None if s is None else s - base)
                 for (_, m), s in zip(screens[2 * k:2 * k + 2], screened[2 * k:2 * k + 2],
                                      strict=True)]
        column = signature(measured - base, sides)
        if column is not None:
            blocks[c] = column
    return base, blocks


def _newton(replayer: Replayer, measured: np.ndarray, base: np.ndarray,
            blocks: dict[str, np.ndarray], world: list[str], offsets: dict[str, np.ndarray],
            params: LogDiagnosisParams) -> dict[str, Any]:
    """Gauss-Newton on the world causes' magnitudes, each step replayed; the best replayed
    fit, its offsets (closed form) and whether it beats the lab's world by the gain asked."""
    start_fit, start_left = solve(measured - base, offsets, None, _fixed(offsets))
    best = {"magnitudes": {}, "simulated": base, "left": start_left,
            "offsets": start_fit, "confirmed": False}
    if not world:
        return best
    jacobian = np.concatenate([blocks[c] for c in world], axis=1)
    magnitudes, simulated = np.zeros(len(world)), base
    for _ in range(params.newton_steps + 1):
        fitted, _ = solve(measured - simulated, {"world": jacobian, **offsets}, None,
                          _fixed(offsets))
        target = np.clip(magnitudes + fitted["world"], -MAX_MAGNITUDE, MAX_MAGNITUDE)
        (replayed,) = replayer.batches([dict(zip(world, target.tolist(), strict=True))])
        if replayed is None:
            break
        jacobian = broyden(jacobian, target - magnitudes, replayed - simulated)
        magnitudes, simulated = target, replayed
        fitted, left = solve(measured - simulated, offsets, None, _fixed(offsets))
        if rmse_n(left) < rmse_n(best["left"]):
            best = {"magnitudes": dict(zip(world, magnitudes.tolist(), strict=True)),
                    "simulated": simulated, "left": left, "offsets": fitted,
                    "jacobian": jacobian}
    if best["magnitudes"]:
        best = _stretch(replayer, measured, offsets, world, best)
    best["confirmed"] = bool(best["magnitudes"]) and (
        rmse_n(best["left"]) <= (1.0 - params.min_heldout_gain) * rmse_n(start_left))
    return best


def _stretch(replayer: Replayer, measured: np.ndarray, offsets: dict[str, np.ndarray],
             world: list[str], best: dict[str, Any]) -> dict[str, Any]:
    """A line search along the lab's world to the best fit: the fitted magnitudes scaled by
    :data:`STRETCH` while that lowers the replayed error, or once by its inverse where the
    first stretch does not. A cause's response flattens as it grows (a turned fibre, a
    stiffer muscle), so signatures taken at the screening step and Gauss-Newton on them stop
    short of a strong cause."""
    direction = np.array([best["magnitudes"][c] for c in world])
    scale, factor = 1.0, STRETCH
    for _ in range(STRETCH_REPLAYS):
        trial = np.clip(direction * scale * factor, -MAX_MAGNITUDE, MAX_MAGNITUDE)
        (replayed,) = replayer.batches([dict(zip(world, trial.tolist(), strict=True))])
        better = False
        if replayed is not None:
            fitted, left = solve(measured - replayed, offsets, None, _fixed(offsets))
            if rmse_n(left) < rmse_n(best["left"]):
                best = {**best, "magnitudes": dict(zip(world, trial.tolist(), strict=True)),
                        "simulated": replayed, "left": left, "offsets": fitted}
                scale, better = scale * factor, True
        if not better:
            if factor < 1.0 or scale != 1.0:
                break
            factor = 1.0 / STRETCH
    return best


def _heldout_replays(replayer: Replayer, measured: np.ndarray, rows: Rows,
                     fit: dict[str, Any], world: list[str], offsets: dict[str, np.ndarray]
                     ) -> np.ndarray:
    """Each log's residual in the world of ``world``'s causes fitted on the other logs (a
    Gauss-Newton step from the batch's fit on their rows), replayed."""
    residual = measured - fit["simulated"]
    left = np.empty_like(measured)
    jobs, fits = [], []
    for i in range(len(replayer.folders)):
        others = rows.log != i
        fitted, _ = solve(residual, {"world": fit["jacobian"], **offsets}, others,
                          _fixed(offsets))
        moved = np.clip(np.array([fit["magnitudes"][c] for c in world]) + fitted["world"],
                        -MAX_MAGNITUDE, MAX_MAGNITUDE)
        jobs.append((i, dict(zip(world, moved.tolist(), strict=True))))
        fits.append(fitted)
    for i, (vector, fitted) in enumerate(zip(replayer.run(jobs), fits, strict=True)):
        mine = rows.log == i
        simulated = fit["simulated"][mine] if vector is None else vector
        correction = sum((offsets[c] @ fitted[c] for c in offsets), np.zeros(measured.size))
        left[mine] = measured[mine] - simulated - correction[mine]
    return left


def _fixed(blocks: dict[str, np.ndarray]) -> frozenset[str]:
    """The offsets among ``blocks``: fitted at rest, taken whole."""
    return frozenset(name for name in blocks if name.startswith(_OFFSET))


def _offset_n(column: np.ndarray, rows: Rows, scale: np.ndarray) -> list[float]:
    """The offset (N, each component) that an offset's column times ``scale`` adds."""
    first = [int(np.flatnonzero((column[:, 0] != 0) & (rows.axis == k))[0])
             if ((column[:, 0] != 0) & (rows.axis == k)).any() else None for k in range(3)]
    return [0.0 if i is None else float(column[i, 0] * scale[0]) for i in first]


def _candidates(residual: np.ndarray, blocks: dict[str, np.ndarray], rows: Rows,
                chosen: list[str]) -> list[dict[str, Any]]:
    """Every block screened, alone: its linearised magnitude and held-out RMSE."""
    out = []
    for name, columns in blocks.items():
        alone = {name: columns}
        fitted, _ = solve(residual, alone, None, _fixed(alone))
        entry: dict[str, Any] = {"cause": name.split(":")[0],
                                 "heldout_rmse_N": rmse_n(heldout(residual, alone, rows,
                                                                  _fixed(alone))),
                                 "selected": name in chosen, "linearised": True}
        if name.startswith(_OFFSET):
            entry["params"] = {"channel": name.removeprefix(_OFFSET),
                               "offset_N": _offset_n(columns, rows, fitted[name])}
        else:
            entry["params"] = magnitudes_json({name: float(fitted[name][0])})[name]
        out.append(entry)
    return out


def _evidence(residual: np.ndarray, blocks: dict[str, np.ndarray], rows: Rows,
              chosen: list[str], left: np.ndarray) -> dict[str, dict[str, Any]]:
    """Per named block, the held-out RMSE of the logs with the extended world (replayed) and
    without the block (linearised), and the share of the logs it improves."""
    out = {}
    for name in chosen:
        others = {c: blocks[c] for c in chosen if c != name}
        without = heldout(residual, others, rows, _fixed(others))
        logs = np.unique(rows.log)
        better = [rmse_n(left[rows.log == i]) < rmse_n(without[rows.log == i]) for i in logs]
        out[name] = {"heldout_rmse_N": rmse_n(left), "without_heldout_rmse_N": rmse_n(without),
                     "logs_improved_share": float(np.mean(better))}
    return out
