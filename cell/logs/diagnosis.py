"""The diagnosis of a batch of separation logs (docs/logs.md): what the simulation gets
wrong about them, why, and the world that gets it right, in the contract of the measurement
sets (baseline, causes, candidates with evidence, extended, held-out error, gain), held out
by leave-one-log-out.

A replay is an episode, so the search is kept to about a hundred of them: five replays of
every log in the lab's world (the baseline, and four nudged, whose spread weighs each sample:
:mod:`cell.logs.chaos`), two per log and cause with the cause's screening
magnitude one way and the other (its linearised signature: the change of every channel at
every sample), a greedy forward selection on those signatures (:mod:`cell.logs.fit`: a
sensor's offset is a constant on its channel, in closed form), Gauss-Newton steps on the
causes selected, each confirmed by replaying the batch (Broyden's update keeps the
signatures true to the replays), a line search along the fit, and one replay per log left
out, in the world fitted on the others: unless those lower the held-out error by the gain
asked, the world's causes are not named (a change that fits the logs it was fitted to but no
log left out). A confirmed fit gets a second look: the other causes screened again in the
fitted world, where a cause the first hid may show, and kept on the same terms
(:mod:`cell.logs.second_look`). The causes that stand are named only where the world they
make beats the lab's by that gain in the median of nudged replays as well (a separation is
close to chaotic: :mod:`cell.logs.spread`). Replays run side by side on every core, or on a
Ray cluster (:mod:`cell.logs.replays`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cell.cores import default_workers
from cell.diagnosis.engine.determined import NOT_PREDICTED, determined
from cell.diagnosis.engine.outcome import force_noise_n
from cell.logs.batch import LogBatch
from cell.logs.causes import CAUSES, SENSOR_OFFSET, applicable, magnitudes_json
from cell.logs.chaos import chaos_scales, noise_variance
from cell.logs.evidence import (
    Indistinguishable,
    LogEvidence,
    UndeterminedBeside,
    candidates,
    indistinguishable,
    log_evidence,
    offset_n,
    undetermined_beside,
)
from cell.logs.fit import (
    FORCE_CHANNELS,
    Rows,
    Step,
    broyden,
    decorrelation_rows,
    forward_selection,
    heldout,
    logged_vector,
    rmse_n,
)
from cell.logs.nudges import nudged, nudges
from cell.logs.outcome import EVIDENCE_ROWS, count_entries, evidence_weight
from cell.logs.replays import Progress, Replayer, ReplayPool
from cell.logs.search import (
    OFFSET,
    Fit,
    dropped,
    fixed,
    from_probes,
    gauss_newton,
    heldout_replays,
    located_sides,
    mirrored,
    outcome_locators,
    pruned,
    replayed_fit,
    screening_worlds,
    signatures,
)
from cell.logs.second_look import confirmed_second_look
from cell.logs.spread import spread_checked

#: What a fit says beyond its magnitudes, carried into ``extended``.
EXTENDED_KEYS = ("dropped", "second_look", "pruned", "spread", "replay_scatter")


@dataclass(frozen=True)
class LogDiagnosisParams:
    """How the batch diagnosis searches.

    Attributes:
        workers: replays side by side on this machine (None: one per core, at least one a
            log); on a cluster (:func:`diagnose_logs`'s ``cluster``), its pool says how many.
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
        evidence: per named cause (an offset per channel), the held-out RMSE with and
            without it (:class:`~cell.logs.evidence.LogEvidence`).
        steps: the forward selection's steps.
        simulated: the simulated vectors of the baseline and the extended world.
        timing: replays, their wall and CPU time, and the fits' (the rest's), s.
        noise_n: the logged force channels' noise (the engine's
            :func:`~cell.diagnosis.engine.outcome.force_noise_n`), N.
        indistinguishable: the causes screened that the batch cannot tell from a named one
            (:func:`~cell.logs.evidence.indistinguishable`).
        undetermined_beside: the causes screened that the batch can neither confirm nor rule
            out beside the named ones (:func:`~cell.logs.evidence.undetermined_beside`).

    Example:
        >>> LogDiagnosis(["a", "b"], [2.0, 2.0], [], [], {}, {"baseline": 2.0, "extended": 1.5},
        ...              [], [], {}, {}).gain
        0.25
    """

    logs: list[str]
    baseline_rmse_n: list[float]
    causes: list[str]
    candidates: list[dict[str, Any]]
    extended: dict[str, Any]
    heldout_rmse_n: dict[str, float]
    evidence: list[LogEvidence]
    steps: list[dict[str, Any]]
    simulated: dict[str, np.ndarray] = field(repr=False)
    timing: dict[str, float]
    noise_n: float = 0.0
    indistinguishable: list[Indistinguishable] = field(default_factory=list)
    undetermined_beside: list[UndeterminedBeside] = field(default_factory=list)

    @property
    def gain(self) -> float:
        """``1 - extended / baseline`` held-out RMSE."""
        base = self.heldout_rmse_n["baseline"]
        return 1.0 - self.heldout_rmse_n["extended"] / base if base > 0 else 0.0

    def to_json(self) -> dict[str, Any]:
        """The search outcome's JSON shape of every diagnosis
        (:meth:`cell.diagnosis.engine.outcome.SearchOutcome.to_json`: ``baseline``,
        ``causes``, ``candidates``, ``extended``, ``gain``, ``noise_N``, ``steps``,
        ``second_look``, ``evidence``) with the logs' own keys (``logs``, ``timing``; a step's
        ``added`` and ``round``); a score the replays do not determine ``null`` with its
        reason (:mod:`cell.diagnosis.engine.determined`)."""
        tried = self.extended.get("second_look")
        return {"logs": self.logs,
                "baseline": {"model": "the logs' scenarios as the lab believes them",
                             "params": {}, **determined("rmse_N", self.baseline_rmse_n),
                             **_score("heldout_rmse_N", self.heldout_rmse_n["baseline"])},
                "causes": self.causes,
                "candidates": [_scored(c) for c in self.candidates],
                "extended": _scored({**self.extended,
                                     "heldout_rmse_N": self.heldout_rmse_n["extended"]}),
                **_score("gain", self.gain), "noise_N": self.noise_n,
                "steps": [_scored(s) for s in self.steps],
                "second_look": [] if tried is None else [tried],
                "evidence": [e.to_json() for e in self.evidence],
                "indistinguishable": [i.to_json() for i in self.indistinguishable],
                "undetermined_beside": [u.to_json() for u in self.undetermined_beside],
                "timing": self.timing}


def _score(name: str, value: float) -> dict[str, Any]:
    """A score of the replays, ``null`` where a replay's residual did not stay finite."""
    return determined(name, value, NOT_PREDICTED)


def _scored(entry: dict[str, Any]) -> dict[str, Any]:
    """``entry`` with its scores (RMSE, information criterion) through :func:`_score`."""
    return {**entry, **{key: item for name in ("rmse_N", "heldout_rmse_N", "information")
                        if name in entry for key, item in _score(name, entry[name]).items()}}


def diagnose_logs(batch: LogBatch, params: LogDiagnosisParams | None = None,
                  cluster: ReplayPool | None = None,
                  progress: Progress | None = None) -> LogDiagnosis:
    """Diagnose ``batch`` (module docstring), its replays on ``params.workers`` processes
    here, or on ``cluster`` (an entered :class:`cell.scale.pool.RunPool` on a Ray cluster,
    whose ``Workers`` then say how many run at a time); ``progress`` (a progress bar) counts
    the replays done of those planned and names the round.

    Raises:
        DivergenceError: the lab's own world blew up in a replay.
        PoolError: a replay on ``cluster`` gave no result (its worker or node died).
    """
    params = params or LogDiagnosisParams()
    measured, rows = logged_vector(batch.logs, EVIDENCE_ROWS)
    names = [c for c in applicable(batch.scenarios[0])
             if params.causes is None or c in params.causes]
    workers, noise_n = params.workers or default_workers(len(batch.logs)), _noise_n(batch)
    started, cpu_started = time.perf_counter(), time.process_time()
    jobs = len(batch.logs) * (sum(len(CAUSES[c].probes(True)) for c in names) + 1)
    with Replayer(batch, min(workers, jobs), cluster) as replayer:
        replayer.progress = progress
        measured, base, blocks, locators = _screen(replayer, measured, rows, names, noise_n)
        scale = np.concatenate(replayer.scales)
        residual = measured - base
        steps = forward_selection(residual, blocks, rows, params.min_heldout_gain,
                                  frozenset(OFFSET + ch for ch in FORCE_CHANNELS))
        chosen = [step.added for step in steps[1:]]
        world = [c for c in chosen if c in CAUSES]
        offsets = {c: blocks[c] for c in chosen if c.startswith(OFFSET)}
        start = replayed_fit(measured, base, {}, offsets)
        fit, world = _first_fit(replayer, measured, start, blocks, world, offsets, params,
                                locators)
        chosen = [c for c in chosen if c in world or c not in CAUSES]
        without = heldout(residual, offsets, rows, fixed(offsets))
        screened = [c for c in names if c in blocks]
        left = (heldout_replays(replayer, measured, rows, fit, world, offsets, start, without,
                                params.min_heldout_gain, screened)
                if fit["confirmed"] else without)
        second: list[Step] = []
        if world and (not fit["confirmed"] or rmse_n(left)
                      > (1.0 - params.min_heldout_gain) * rmse_n(without)):
            # Only the offsets stand when the world's causes do not lower the error of the logs
            # they were fitted to, or do but not of each log left out (the change does not
            # carry from one separation to the next): then they are named as dropped.
            gone = dropped(world, fit, left, without) if fit["confirmed"] else None
            world, left = [], without
            fit = {**start, "confirmed": False, **({"dropped": gone} if gone else {})}
        elif world:
            fit, left, kept, second = confirmed_second_look(
                replayer, measured, rows, fit, world, left, screened,
                offsets, params.min_heldout_gain, params.newton_steps)
            chosen = [c for c in chosen if c in kept or c not in CAUSES]
            chosen += [c for c in kept if c not in chosen]
            world = kept
        if world:
            fit, world, left = spread_checked(replayer, measured, rows, fit, world, left,
                                              screened, offsets,
                                              start, without, params.min_heldout_gain)
            chosen = [c for c in chosen if c in world or c not in CAUSES]
    steps_json = _steps_json(steps, second)
    causes = world + ([SENSOR_OFFSET] if offsets else [])
    baseline = [rmse_n(residual[rows.log == i]) for i in range(len(batch.logs))]
    heldout_rmse = {"baseline": rmse_n(residual), "extended": rmse_n(left)}
    offset_fit = {c.removeprefix(OFFSET): offset_n(offsets[c], rows, fit["offsets"][c], scale)
                  for c in offsets}
    extended = {"model": "the logs' scenarios with the causes' changes",
                "params": {**magnitudes_json(fit["magnitudes"]),
                           **({SENSOR_OFFSET: offset_fit} if offset_fit else {})},
                "rmse_N": rmse_n(fit["left"]), "confirmed": fit["confirmed"],
                "evidence_weight_N": replayer.weight,
                **{key: fit[key] for key in EXTENDED_KEYS if key in fit}}
    return LogDiagnosis(
        [log.name for log in batch.logs], baseline, causes,
        candidates(residual, blocks, rows, chosen, scale), extended, heldout_rmse,
        log_evidence(residual, blocks, rows, chosen, left),
        steps_json, {"baseline": base / scale, "extended": fit["simulated"] / scale,
                     "measured": measured / scale},
        _timing(replayer, started, cpu_started), noise_n,
        indistinguishable(residual, blocks, rows, chosen, world, params.min_heldout_gain),
        undetermined_beside(residual, blocks, rows, chosen, world, params.min_heldout_gain))


def _first_fit(replayer: Replayer, measured: np.ndarray, start: Fit,
               blocks: dict[str, np.ndarray], world: list[str], offsets: dict[str, np.ndarray],
               params: LogDiagnosisParams, locators: dict[str, float]
               ) -> tuple[Fit, list[str]]:
    """Gauss-Newton on the causes selected from their screening signatures, from the lab's
    world (``start``) or, where it fits better, where the causes' outcome locators put them
    (:func:`~cell.logs.search.outcome_locators`), an angle tried the other way (``mirrored``),
    the fit started again from a closer screening replay (``from_probes``), less the causes
    that do not earn their place (``pruned``; the causes left returned); and whether its
    replays beat the lab's world by the gain asked (:mod:`cell.logs.search`)."""
    if not world:
        return {**start, "confirmed": False}, world
    replayer.round = "fit"
    jacobian = np.concatenate([blocks[c] for c in world], axis=1)
    begin = _located(replayer, measured, start, world, jacobian, offsets, locators)
    fit = gauss_newton(replayer, measured, offsets, begin, world,
                       begin.get("jacobian", jacobian), params.newton_steps)
    fit = mirrored(replayer, measured, offsets, fit, world, params.newton_steps)
    fit = from_probes(replayer, measured, offsets, fit, world, jacobian, params.newton_steps)
    fit, world = pruned(replayer, measured, offsets, fit, world, params.min_heldout_gain,
                        params.newton_steps)
    return {**fit, "confirmed": fit is not start and rmse_n(fit["left"])
            <= (1.0 - params.min_heldout_gain) * rmse_n(start["left"])}, world


def _located(replayer: Replayer, measured: np.ndarray, start: Fit, world: list[str],
             jacobian: np.ndarray, offsets: dict[str, np.ndarray],
             locators: dict[str, float]) -> Fit:
    """The world where ``locators`` put ``world``'s causes (the others at 0), replayed, with
    the signatures Broyden-updated to it, where it fits better than ``start``; else
    ``start``."""
    at = {c: locators[c] for c in world if c in locators}
    if not at:
        return start
    (replayed,) = replayer.batches([at])
    if replayed is None:
        return start
    trial = replayed_fit(measured, replayed, at, offsets)
    if rmse_n(trial["left"]) >= rmse_n(start["left"]):
        return start
    step = np.array([at.get(c, 0.0) for c in world])
    return {**trial, "jacobian": broyden(jacobian, step, replayed - start["simulated"])}


def _timing(replayer: Replayer, started: float, cpu_started: float) -> dict[str, float]:
    """Where the time went: the replays (by round) and the rest (the fits, in this process),
    wall and CPU, s."""
    wall = time.perf_counter() - started
    cpu = time.process_time() - cpu_started - (replayer.cpu_s if replayer.in_process else 0.0)
    return {"replays": replayer.count, "replays_by_round": replayer.by_round,
            "replay_wall_s": replayer.wall_s, "fit_s": wall - replayer.wall_s, "total_s": wall,
            "replay_cpu_s": replayer.cpu_s, "fit_cpu_s": cpu}


def _screen(replayer: Replayer, measured: np.ndarray, rows: Rows, names: list[str],
            noise_n: float
            ) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], dict[str, float]]:
    """The logged vector weighed, the baseline's replay, the blocks (each cause's signature,
    :func:`signatures`, and each sensor's offset at rest, weighed) and each cause's outcome
    locator (:func:`outcome_locators`), from the lab's world as it is and nudged
    (:func:`~cell.logs.nudges.nudges`), a batch replay at each cause's probes, near and far
    (:func:`screening_worlds`), and one at each locator the counts point to
    (:func:`located_sides`). From here on every replay's force samples are weighed by the
    nudged replays' spread and the logs' noise ``noise_n`` (N; :mod:`cell.logs.chaos`), its
    misfits beyond them by the weighed force residual
    (:func:`~cell.logs.outcome.evidence_weight`)."""
    worlds = [{}, *screening_worlds(names, {}, wide=True)]
    lab = [nudged({}, shift) for shift in nudges(names)]
    base, *_ = replayed = replayer.batches([*lab, *worlds[1:]])
    if base is None:
        from cell.errors import DivergenceError

        raise DivergenceError(0.0, "a replay of the lab's own world blew up")
    logs = replayer.batch.logs
    scale = chaos_scales(logs, rows, [v for v in replayed[:len(lab)] if v is not None], noise_n)
    replayer.scales = [scale[rows.log == i] for i in range(len(logs))]
    replayer.noise_rmse_n = rmse_n(scale * np.sqrt(noise_variance(logs, rows, noise_n)))
    measured = measured * scale
    force = measured - base * scale
    force[~rows.force] = 0.0
    replayer.weight = evidence_weight(rmse_n(force[rows.force]),
                                      decorrelation_rows(force, rows))
    base, *screened = replayer.batches(worlds)
    counts = count_entries(~rows.force)
    located = located_sides(replayer, base, names, screened, counts)
    blocks = signatures(measured - base, base, names, screened, wide=True, located=located)
    blocks.update({OFFSET + ch: rows.resting_offset((measured - base) / scale, ch)
                   * scale[:, None] for ch in FORCE_CHANNELS})
    return measured, base, blocks, outcome_locators(base, names, screened, counts)


def _steps_json(first: list[Step], second: list[Step]) -> list[dict[str, Any]]:
    """The selection's steps (the first round's, then the second look's) as the engine's
    ``steps`` (``causes``: the blocks in the model after the step) with the block ``added``
    and the ``round``."""
    out, causes = [], []
    for round_, part in ((1, first), (2, second)):
        for step in part:
            causes = [*causes, step.added] if step.added else causes
            out.append({"causes": causes, "added": step.added, "information": step.information,
                        "heldout_rmse_N": step.heldout_rmse_n, "round": round_})
    return out


def _noise_n(batch: LogBatch) -> float:
    """The force noise of the logged channels, each component of each channel of each log a
    series (:func:`~cell.diagnosis.engine.outcome.force_noise_n`), N."""
    return force_noise_n(log.channels[name].force_n[:, k] for log in batch.logs
                         for name in FORCE_CHANNELS for k in range(3))
