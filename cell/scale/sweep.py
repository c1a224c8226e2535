"""``musclecell sweep``: every run of a sweep file, one Ray task each, into a results folder
that a re-run resumes.

The folder gets ``results.parquet`` and ``results.csv`` (one row per run: the swept values,
status, error and the summary's ``result``), one plot per swept variable
(``<variable>.png``), ``summary.md``, the runs' records in ``runs/`` and, when the sweep asks
for them, ``recordings/<run>.rrd``.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from cell.errors import InputError, SweepError
from cell.extras import require
from cell.learning.baselines import PolicySpec, policy_folder
from cell.learning.environments import make_env
from cell.learning.evaluate import EpisodeTask
from cell.outputs import write_atomic
from cell.scale.design import design
from cell.scale.overrides import nested, override_scenario
from cell.scale.pool import Workers
from cell.scale.report import summary_markdown, write_plots
from cell.scale.resume import play_missing
from cell.scale.runs import RunOutcome, RunTask, failed_row, play
from cell.scale.spec import SweepSpec, load_sweep
from cell.scale.store import ResultsFolder, fingerprint
from cell.sim.scenario import load_scenario

TABLE = "results"


@dataclass(frozen=True)
class SweepOutcome:
    """A finished sweep: every run's row (by run index), how many runs were played now and
    how many were found finished in the folder, the wall time (s), the part of it that
    played the runs and the part of that which started or joined Ray (s), the files
    written."""

    rows: list[dict[str, Any]]
    played: int
    skipped: int
    wall_s: float
    play_s: float
    startup_s: float
    files: list[Path]


def prepare(spec: SweepSpec) -> list[RunTask]:
    """The sweep's runs, each with its scenario (or env episode) built and checked here,
    before any run: a bad key or value raises now, naming the sweep file and the key.

    Example:
        >>> tasks = prepare(load_sweep("scenarios/sweeps/binding_strength.toml"))
        >>> len(tasks), tasks[1].scenario.cut.speed_m_s, tasks[1].scenario.seed
        (24, 0.05, 1)
    """
    points = design(spec)
    if spec.policy is None:
        base = override_scenario(load_scenario(spec.scenario_path), spec.overrides,
                                 file=spec.path, section="overrides")
        return [RunTask(p, override_scenario(replace(base, seed=p.seed), p.values,
                                             file=spec.path, section="variables"),
                        record=spec.head.record) for p in points]
    folder = ""
    if spec.policy.name == "learned":
        try:
            folder = str(policy_folder(spec.policy_folder))
        except InputError as exc:
            raise SweepError(spec.path, "policy.folder", str(exc)) from None
    kwargs = [nested({**spec.overrides, **p.values}) for p in points]
    try:  # one env built here: an unknown keyword fails now, not in every run
        make_env(spec.policy.env, kwargs[0]).close()
    except InputError as exc:
        raise SweepError(spec.path, "variables", exc.message) from None
    policy = PolicySpec(spec.policy.name, folder=folder)
    return [RunTask(p, episode=EpisodeTask(spec.policy.env, json.dumps(k, sort_keys=True),
                                           policy, p.seed))
            for p, k in zip(points, kwargs, strict=True)]


def run_sweep(sweep_file: str | Path, out: str | Path, workers: Workers, *,
              retry_failed: bool = False, progress: bool = True) -> SweepOutcome:
    """Play the sweep's runs that ``out`` does not hold yet (with ``retry_failed``, those that
    failed or diverged too), then write the table, the plots and the summary of all of them.

    Raises:
        SweepError: a bad sweep file (naming it and the key).
        PoolError: no Ray, or a cluster that cannot be reached.
        MissingExtraError: no matplotlib for the plots.
        ScenarioError: a bad base scenario.
    """
    started = time.perf_counter()
    spec = load_sweep(sweep_file)
    tasks = prepare(spec)
    require("matplotlib", "scale", "the sweep's plots")
    results = ResultsFolder(out)

    def keep(name: str, outcome: RunOutcome | None, error: str) -> dict[str, Any]:
        if outcome is None:
            point = next(task.point for task in tasks if task.point.name == name)
            return {"row": failed_row(point, error), "traceback": ""}
        row = outcome.row
        if outcome.recording is not None:
            path = write_atomic(results.folder / "recordings" / f"{name}.rrd",
                                outcome.recording)
            row = {**row, "recording": str(path.relative_to(results.folder))}
        return {"row": row, "traceback": outcome.traceback}

    played = play_missing(play, tasks, [task.point.name for task in tasks],
                          [fingerprint(task) for task in tasks], results, workers, keep=keep,
                          retry_failed=retry_failed, progress=progress, desc=spec.path.stem)
    variables = list(spec.variables)
    files = [*results.write_table(TABLE, played.rows)]
    plots = write_plots(results.folder, played.rows, variables)
    summary = summary_markdown(spec.path.stem, played.rows, variables, plots)
    files += [*plots, write_atomic(results.folder / "summary.md", summary)]
    return SweepOutcome(played.rows, played.played, len(tasks) - played.played,
                        time.perf_counter() - started, played.play_s, played.startup_s, files)
