"""``musclecell bench diagnose --logs``: the batch diagnosis of separation logs
(:func:`~cell.logs.diagnosis.diagnose_logs`, what ``musclecell diagnose-logs`` runs) on
hidden-effect log batches it has never seen.

Each batch is drawn by the project's generator (:func:`~cell.synthetic.logs.write_hidden_log_batch`:
three separations of drawn meat shapes on ``scenarios/quick.toml``, one or two hidden changes of
the world, sensor noise) with a seed the tests never use, read back as one batch and diagnosed.
Four kinds (:data:`KINDS`): ``single`` cycles through the log cause table of docs/logs.md
(:func:`log_table`, read from the causes' registry) and none; ``pairs`` through every pair of
it; ``keys`` and ``key-pairs`` likewise (but the sensor's offset), their worlds made the way a
user makes one, by editing the scenario keys each cause maps to, by factors of 0.4 to 2.5 on
shapes drawn from the documented ranges (:mod:`cell.bench.keyworlds`). The ``--quick`` form
(:meth:`LogBenchParams.quick`) cuts every episode short, for iteration only: its figures are no
acceptance figures.

Per batch: whether the causes named are exactly the hidden ones; each hidden cause's fitted
magnitude against the truth (:func:`magnitude_error`); the held-out gain; the diagnosis's wall
and CPU seconds split into the replays' and the fits' (the replays run in worker processes:
their CPU is the workers'); the seconds of the episodes that made the batch; and which hidden
changes its logs show at all (:func:`~cell.bench.visibility.visibility`), with the exact rate
where they do beside the exact rate (the target); and for a batch named wrong, whether its
logs put the true world ahead of the world named (a miss of the search) or cannot tell the two
apart (``truth_preferred``).

Targets: exact on >= 80 % of single batches and >= 60 % of pairs, the fitted
magnitude within 20 % of the truth in >= 75 % of the single batches with a cause, none named in
every batch with none, a median held-out gain >= 0.5 on the single batches with a cause, a
diagnosis median <= 5 min and max <= 10 min per batch of three logs. The key-edit kinds: exact
on >= 90 % of ``keys`` batches and >= 4 of 6 ``key-pairs``, the magnitude within 25 % in >= 90 %
of the ``keys`` batches with a change, none named on >= 4 of 5 batches without one.
"""

from __future__ import annotations

import itertools
import math
import statistics
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from cell.bench.diagnose import (
    cause_label,
    check_request,
    confusion_markdown,
    cycled_causes,
    fraction,
    time_summary,
)
from cell.logs.causes import SENSOR_OFFSET, table_causes
from cell.progress import progress_bar
from cell.sim.examples import SCENARIOS

if TYPE_CHECKING:
    from cell.logs.replays import Progress, ReplayPool

Kind = Literal["single", "pairs", "keys", "key-pairs"]
KINDS: tuple[Kind, ...] = ("single", "pairs", "keys", "key-pairs")
#: The kinds whose worlds are made by editing scenario keys (:mod:`cell.bench.keyworlds`).
KEY_KINDS = ("keys", "key-pairs")
#: The first seed of each kind. The tests use seeds below 100; the diagnosis of logs is tuned
#: on the seeds of :data:`TUNING_SEEDS`, never on these.
FIRST_SEED: dict[str, int] = {"single": 70_000, "pairs": 71_000, "keys": 72_000,
                              "key-pairs": 73_000}
TUNING_SEEDS = range(78_000, 79_000)
#: Batches with no hidden cause after each pass through the table.
NONES_PER_CYCLE = 3
#: The base scenario of every batch.
BASE_SCENARIO = SCENARIOS / "quick.toml"
#: Where the ``--quick`` form ends every episode, s (the cut is half done, the pull under way).
QUICK_END_S = 8.0
TARGET_CORRECT: dict[str, float] = {"single": 0.8, "pairs": 0.6, "keys": 0.9,
                                    "key-pairs": 4 / 6}
#: A fitted magnitude within this share of the truth counts, by kind.
MAGNITUDE_TOLERANCE: dict[str, float] = {"single": 0.2, "pairs": 0.2, "keys": 0.25,
                                         "key-pairs": 0.25}
TARGET_MAGNITUDE_WITHIN: dict[str, float] = {"single": 0.75, "keys": 0.9}
TARGET_GAIN_MEDIAN = 0.5
TARGET_SECONDS_MEDIAN = 300.0
TARGET_SECONDS_PER_BATCH = 600.0


@dataclass(frozen=True)
class LogBenchParams:
    """How the bench draws and diagnoses its batches.

    Attributes:
        base: the scenario the batches are drawn on.
        end_s: every episode (and so every log) cut short here, s (None: whole).
        workers: replays side by side (None: one per core, at least one a log; on a cluster,
            as many as it takes).

    Example:
        >>> LogBenchParams.quick(workers=2).end_s
        8.0
    """

    base: Path = BASE_SCENARIO
    end_s: float | None = None
    workers: int | None = None

    @classmethod
    def quick(cls, workers: int | None = None) -> LogBenchParams:
        """Short episodes, for iteration."""
        return cls(end_s=QUICK_END_S, workers=workers)


def bench_seeds(count: int, kind: Kind = "single", first: int | None = None) -> list[int]:
    """The seeds of ``count`` bench batches of ``kind``, from ``first`` (default the kind's
    :data:`FIRST_SEED`)."""
    start = FIRST_SEED[kind] if first is None else first
    return [start + i for i in range(count)]


def log_table(kind: Kind = "single") -> tuple[str, ...]:
    """The log cause table (docs/logs.md): the registry's causes of it
    (:func:`~cell.logs.causes.table_causes`) and ``sensor_offset``, which a key-edit kind
    leaves out (a sensor has no scenario key); a cause of the cut cause table
    (docs/measured-data.md, ``blade_friction``) is benched by ``--cut``."""
    table = table_causes("logs")
    return tuple(c for c in table if c != SENSOR_OFFSET) if kind in KEY_KINDS else table


def log_pairs(kind: Kind = "pairs") -> tuple[tuple[str, str], ...]:
    """Every pair of the log cause table, the pair kinds' batches."""
    return tuple(itertools.combinations(log_table(kind), 2))


def hidden(seed: int, kind: Kind) -> tuple[str, ...]:
    """The causes hidden in the batch of ``seed``: the log table in turn, then none three
    times (single: 20 batches hold each cause twice and none six times), or every pair of it
    in turn.

    Example:
        >>> hidden(70_000, "single"), hidden(70_009, "single"), hidden(70_010, "single")
        (('binding_strength',), (), ('binding_strength',))
    """
    return cycled_causes(seed - FIRST_SEED[kind], log_table(kind), NONES_PER_CYCLE,
                         log_pairs(kind) if kind in ("pairs", "key-pairs") else None)


def magnitude_error(cause: str, truth: Mapping[str, Any], offset_channel: str,
                    fitted: Mapping[str, Any]) -> float:
    """The fitted magnitude's error relative to the truth: of the factor, of the angle, or of
    the offset's vector (its norm over the truth's; infinite on another channel).

    Args:
        cause: a hidden cause.
        truth: the truth's magnitudes (:class:`~cell.synthetic.logs.LogBatchTruth`: factors, an
            angle in rad, an offset in N).
        offset_channel: the channel the hidden offset is on.
        fitted: the extended world's ``params`` (``diagnosis.json``): per cause its
            ``factor`` or ``angle_deg``, the offsets by channel. A cause not there: infinite.

    Example:
        >>> magnitude_error("tissue_stiffness", {"tissue_stiffness": 0.5}, "",
        ...                 {"tissue_stiffness": {"magnitude": -0.29, "factor": 0.75}})
        0.5
    """
    if cause not in fitted:
        return math.inf
    if cause == SENSOR_OFFSET:
        found = fitted[cause].get(offset_channel)
        expected = truth[cause]
        if found is None:
            return math.inf
        difference = math.dist(found, expected)
        return difference / max(math.hypot(*expected), 1e-12)
    if "angle_deg" in fitted[cause]:
        value = math.radians(fitted[cause]["angle_deg"])
    else:
        value = fitted[cause]["factor"]
    return abs(value - truth[cause]) / max(abs(truth[cause]), 1e-12)


def _batch_row(seed: int, expected: tuple[str, ...], truth: Any, data: dict[str, Any],
               tolerance: float, seen: dict[str, Any]) -> dict[str, Any]:
    """One batch's JSON row from its truth, its ``diagnosis.json`` contract and what of the
    truth its logs show (:func:`~cell.bench.visibility.visibility`)."""
    timing = data["timing"]
    shown = {c for c in expected if seen["visible"].get(c, True)}
    named = set(data["causes"])
    errors = {c: magnitude_error(c, truth.magnitudes, truth.offset_channel,
                                 data["extended"]["params"])
              for c in expected}
    return {"seed": seed, "truth": {"causes": list(expected), "magnitudes": truth.magnitudes,
                                    "offset_channel": truth.offset_channel},
            "causes": list(data["causes"]), "correct": sorted(data["causes"]) == sorted(expected),
            "fitted": data["extended"]["params"],
            "second_look": data["extended"].get("second_look"),
            "spread": data["extended"].get("spread"),
            "replay_scatter": data["extended"].get("replay_scatter"),
            "dropped": data["extended"].get("dropped"),
            "indistinguishable": data.get("indistinguishable", []),
            "undetermined_beside": data.get("undetermined_beside", []),
            "magnitude_error": {c: (None if math.isinf(e) else e) for c, e in errors.items()},
            "magnitude_within": bool(expected) and all(e <= tolerance
                                                       for e in errors.values()),
            "visible": seen["visible"], "lab_rmse_N": seen["lab_rmse_N"],
            "truth_rmse_N": seen["truth_rmse_N"], "visible_p": seen["p_value"],
            "visibility_replays": seen["replays"],
            "named_rmse_N": seen["named_rmse_N"], "truth_preferred": seen["truth_preferred"],
            "truth_preferred_p": seen["truth_preferred_p"],
            "correct_where_visible": shown <= named <= set(expected),
            "gain": float(data["gain"]),
            "heldout_rmse_N": {"baseline": data["baseline"]["heldout_rmse_N"],
                               "extended": data["extended"]["heldout_rmse_N"]},
            "replays": timing["replays"], "seconds": timing["total_s"],
            "cpu_seconds": timing["replay_cpu_s"] + timing["fit_cpu_s"],
            "split": {"replay_wall_s": timing["replay_wall_s"], "fit_wall_s": timing["fit_s"],
                      "replay_cpu_s": timing["replay_cpu_s"], "fit_cpu_s": timing["fit_cpu_s"],
                      "replays_by_round": timing["replays_by_round"]},
            "simulation_seconds": truth.wall_s}


def run_one(folder: Path, seed: int, kind: Kind, params: LogBenchParams,
            cluster: ReplayPool | None = None, progress: Progress | None = None
            ) -> dict[str, Any]:
    """Draw, write, read and diagnose the batch of ``seed`` (its replays on ``cluster``, an
    entered :class:`cell.scale.pool.RunPool`, where given; the diagnosis's replays shown on
    ``progress``): its row of the bench."""
    from cell.bench.keyworlds import write_key_change_batch
    from cell.bench.visibility import visibility
    from cell.logs.batch import read_log_batch
    from cell.logs.diagnosis import LogDiagnosisParams, diagnose_logs
    from cell.synthetic.logs import LOG_COUNT, world_changes, write_hidden_log_batch

    expected = hidden(seed, kind)
    write = write_key_change_batch if kind in KEY_KINDS else write_hidden_log_batch
    truth = write(folder, seed, params.base, expected, end_s=params.end_s)
    batch = read_log_batch([folder / f"log-{k}" for k in range(1, LOG_COUNT + 1)])
    search = LogDiagnosisParams(workers=params.workers)
    data = diagnose_logs(batch, search, cluster, progress).to_json()
    changes = world_changes(expected, truth.magnitudes)
    seen = visibility(batch, changes, params.workers, search.min_heldout_gain, cluster,
                      named_world(data, changes))
    return _batch_row(seed, expected, truth, data, MAGNITUDE_TOLERANCE[kind], seen)


def named_world(data: dict[str, Any], changes: dict[str, float]) -> dict[str, float] | None:
    """The world a diagnosis (its ``diagnosis.json`` contract ``data``) named, cause ->
    magnitude as :func:`~cell.logs.causes.changed_world` takes it, where its causes are not
    those of the true ``changes``; else None.

    Example:
        >>> data = {"causes": ["tearing_threshold"],
        ...         "extended": {"params": {"tearing_threshold": {"magnitude": -0.5}}}}
        >>> named_world(data, {"tearing_threshold": -0.7, "binding_stiffness": 0.4})
        {'tearing_threshold': -0.5}
        >>> named_world(data, {"tearing_threshold": -0.7}) is None
        True
    """
    from cell.logs.causes import CAUSES

    world = {c: float(data["extended"]["params"][c]["magnitude"])
             for c in data["causes"] if c in CAUSES}
    return None if set(world) == set(changes) else world


def run_log_diagnose_bench(seeds: Sequence[int], kind: Kind = "single",
                           params: LogBenchParams | None = None,
                           progress: Callable[[str], None] | None = None,
                           cluster: ReplayPool | None = None,
                           replay_bar: bool = False) -> dict[str, Any]:
    """Draw, write, read and diagnose one hidden-effect log batch of ``kind`` per seed
    (module docstring); the replays on ``cluster`` where given (:func:`run_one`). Each
    batch's line goes to ``progress``; ``replay_bar``: its replays, done of planned, and the
    round on a bar on standard error while it runs.

    Raises:
        MeasurementError: no seed, or an unknown kind.
    """
    check_request(seeds, kind, KINDS)
    params = params or LogBenchParams()
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-log-diagnose-") as scratch:
        for seed in seeds:
            with progress_bar("replay", quiet=not replay_bar, total=0) as bar:
                row = run_one(Path(scratch) / f"batch-{seed}", seed, kind, params, cluster,
                              bar)
            rows.append(row)
            if progress is not None:
                split = row["split"]
                errors = ", ".join(f"{c} {'not fitted' if e is None else f'{e:.1%} off'}"
                                   for c, e in row["magnitude_error"].items())
                progress(f"seed {seed}: truth {cause_label(row['truth']['causes'])}, named "
                         f"{cause_label(row['causes'])}"
                         f"{f' ({errors})' if errors else ''}{_unseen(row)}, "
                         f"gain {row['gain']:.2f}, "
                         f"{row['seconds']:.0f} s ({row['replays']} replays "
                         f"{split['replay_wall_s']:.0f} s, fits {split['fit_wall_s']:.0f} s; "
                         f"CPU {row['cpu_seconds']:.0f} s; simulated in "
                         f"{row['simulation_seconds']:.0f} s)")
    report = summary(rows, kind)
    return {**report, "seeds": list(seeds), "quick": params.end_s is not None,
            "params": {"base": params.base.name, "end_s": params.end_s,
                       "workers": params.workers}}


def _unseen(row: dict[str, Any]) -> str:
    hidden_away = [c for c, shown in row["visible"].items() if not shown]
    told = {True: ", the logs put the truth ahead of the world named",
            False: ", the logs cannot tell the world named from the truth",
            None: ""}[row.get("truth_preferred")]
    return (f", not in these logs: {', '.join(hidden_away)}" if hidden_away else "") + told


def _target(value: float, target: float, unit: str, at_least: bool = True) -> dict[str, Any]:
    passed = value >= target if at_least else value <= target
    return {"value": value, "target": target, "unit": unit, "pass": bool(passed)}


def summary(rows: Sequence[dict[str, Any]], kind: str) -> dict[str, Any]:
    """The bench's JSON from its batch rows (:func:`run_one`): entries, targets, the confusion
    table (truth rows, named columns) and its Markdown."""
    confusion: dict[str, dict[str, int]] = {}
    for row in rows:
        cells = confusion.setdefault(cause_label(row["truth"]["causes"]), {})
        cells[cause_label(row["causes"])] = cells.get(cause_label(row["causes"]), 0) + 1
    with_cause = [r for r in rows if r["truth"]["causes"]]
    without = [r for r in rows if not r["truth"]["causes"]]
    correct = fraction([r["correct"] for r in rows])
    time_entries, time_targets = time_summary([r["seconds"] for r in rows],
                                              TARGET_SECONDS_MEDIAN, TARGET_SECONDS_PER_BATCH)
    cpu = [r["cpu_seconds"] for r in rows]
    split = {key: statistics.median(r["split"][key] for r in rows)
             for key in rows[0]["split"] if key != "replays_by_round"}
    rounds = dict.fromkeys(name for r in rows for name in r["split"]["replays_by_round"])
    entries: dict[str, Any] = {
        **{name.replace("per_set", "per_batch"): entry for name, entry in time_entries.items()},
        "cpu_seconds_per_batch_median": {"value": statistics.median(cpu), "unit": "s"},
        "cpu_seconds_per_batch_max": {"value": max(cpu), "unit": "s"},
        **{f"{key}_median": {"value": value, "unit": "s"} for key, value in split.items()},
        "replays_per_batch_median": {"value": statistics.median(r["replays"] for r in rows),
                                     "unit": "replays"},
        **{f"replays_{name.replace(' ', '_')}_median": {
            "value": statistics.median(r["split"]["replays_by_round"].get(name, 0) for r in rows),
            "unit": "replays"} for name in rounds},
        "simulation_seconds_per_batch_median": {
            "value": statistics.median(r["simulation_seconds"] for r in rows), "unit": "s"},
        "correct": {"value": correct, "unit": "fraction",
                    "count": sum(r["correct"] for r in rows), "of": len(rows)},
        "correct_where_visible": {
            "value": fraction([r["correct_where_visible"] for r in rows]), "unit": "fraction",
            "count": sum(r["correct_where_visible"] for r in rows), "of": len(rows)},
        "changes_not_in_logs": {"value": sum(not v for r in rows for v in r["visible"].values()),
                                "unit": "changes"},
        "misses_truth_preferred": {
            "value": sum(r.get("truth_preferred") is True for r in rows), "unit": "batches",
            "of": sum(not r["correct"] for r in rows)},
    }
    targets = {"correct": _target(correct, TARGET_CORRECT[kind], "fraction"),
               **{name.replace("per_set", "per_batch"): target
                  for name, target in time_targets.items()}}
    if with_cause:
        within = fraction([r["magnitude_within"] for r in with_cause])
        gain = statistics.median(r["gain"] for r in with_cause)
        within_name = f"magnitude_within_{round(100 * MAGNITUDE_TOLERANCE[kind])}_percent"
        entries[within_name] = {"value": within, "unit": "fraction", "of": len(with_cause)}
        entries["heldout_gain_median"] = {"value": gain, "unit": "fraction",
                                          "of": len(with_cause)}
        if kind in ("single", "keys"):
            targets[within_name] = _target(within, TARGET_MAGNITUDE_WITHIN[kind], "fraction")
        if kind == "single":
            targets["heldout_gain_median"] = _target(gain, TARGET_GAIN_MEDIAN, "fraction")
    if without:
        none = sum(not r["causes"] for r in without)
        entries["none_named_without_cause"] = {"value": none, "unit": "batches",
                                               "of": len(without)}
        needed = len(without) if kind not in KEY_KINDS else math.ceil(0.8 * len(without))
        targets["none_named_without_cause"] = _target(none, needed, "batches")
    return {"suite": "diagnose", "kind": f"logs {kind}", "batches": list(rows),
            "entries": entries, "confusion": confusion,
            "markdown": confusion_markdown(confusion), "targets": targets}
