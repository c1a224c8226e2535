"""One run of a sweep, as a worker plays it: a scripted episode of a scenario, or one episode
of a policy in an env, and its row of the results table.

A run that diverges or fails is a row too, with its status and error: a sweep never stops
for one run. The row depends on the run alone (its scenario or env, policy and seed), so the
same run gives the same row in any worker, on any node.
"""

from __future__ import annotations

import json
import tempfile
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cell.errors import DivergenceError
from cell.learning.evaluate import EpisodeTask, run_episode
from cell.scale.design import RunPoint
from cell.scale.failure import describe_failure
from cell.sim.episode import Episode
from cell.sim.mujocolog import warnings_to_stderr
from cell.sim.scenario import Scenario

#: The outcomes the sweep plots against each swept variable.
OUTCOMES = ("released_fraction", "torn_fraction", "knife_force_peak_n")
#: Statuses of a run: it ran to its end, the physics blew up, it failed otherwise (an
#: error, a worker or node that died).
STATUSES = ("ok", "diverged", "failed")
#: Columns of a row that measure the machine, not the run (left out when runs are compared).
TIMING_COLUMNS = ("wall_s",)


@dataclass(frozen=True)
class RunTask:
    """Everything a worker needs to play one run (it pickles, for Ray): the run, and either
    the ``scenario`` of a scripted episode or the ``episode`` of a policy in an env; with
    ``record``, the episode's Rerun recording comes back too."""

    point: RunPoint
    scenario: Scenario | None = None
    episode: EpisodeTask | None = None
    record: bool = False


@dataclass(frozen=True)
class RunOutcome:
    """What a run gives back: its ``row`` (flat: run, seed, swept values, status, error, the
    summary's ``result``, wall time in s), the last lines of a failure's ``traceback``, and
    the bytes of its Rerun ``recording`` when asked for."""

    row: dict[str, Any]
    traceback: str = ""
    recording: bytes | None = None


def play(task: RunTask) -> RunOutcome:
    """Play one run; never raises for the run's own faults (they are its status).

    Example:
        >>> from dataclasses import replace
        >>> from cell.tissue.geometry import MuscleShape
        >>> scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05), end_s=0.1)
        >>> scenario = replace(scenario, perception=replace(scenario.perception, enabled=False))
        >>> row = play(RunTask(RunPoint(0, 0, {"end_s": 0.1}), scenario)).row
        >>> row["status"], row["end_s"], row["released_fraction"]
        ('ok', 0.1, 0.0)
    """
    started = time.perf_counter()
    warnings_to_stderr()  # in a Ray worker too: no MUJOCO_LOG.TXT where it runs
    point = task.point
    head = {"run": point.index, "seed": point.seed, **point.values}
    recording, trace = None, ""
    try:
        if task.scenario is not None:
            result, recording = _episode(task.scenario, task.record)
        else:
            result = _policy_episode(task.episode)
        status, error = "ok", ""
    except DivergenceError as exc:
        result, status, error = {}, "diverged", str(exc)
    except Exception as exc:  # one broken run is recorded as such, never stops the sweep
        result, status = {}, "failed"
        error, trace = describe_failure(exc)
    row = {**head, "status": status, "error": error, **result,
           "wall_s": time.perf_counter() - started}
    return RunOutcome(row, trace, recording)


def failed_row(point: RunPoint, error: str) -> dict[str, Any]:
    """The row of a run that never returned (its worker or node died)."""
    return {"run": point.index, "seed": point.seed, **point.values, "status": "failed",
            "error": error}


def _episode(scenario: Scenario, record: bool) -> tuple[dict[str, Any], bytes | None]:
    """The scripted episode's flat result (with ``torn_fraction`` and ``separated``) and its
    recording's bytes when ``record``."""
    episode = Episode(scenario)
    if record:
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "run.rrd"
            summary = episode.run(rerun_path=path)
            recording = path.read_bytes()
    else:
        summary, recording = episode.run(), None
    result = summary["result"]
    torn = result["released_by_rule"]["tearing"] / max(result["bindings"], 1)
    return {**flat(result), "torn_fraction": torn, "separated": result["muscles_apart"]}, \
        recording


def _policy_episode(task: EpisodeTask) -> dict[str, Any]:
    """The policy episode's return and final info, with ``separated`` (the env's success)."""
    row = run_episode(task)
    kept = {k: v for k, v in row.items() if k not in ("seed", "wall_s")}
    return {**kept, "separated": row["success"]}


def flat(table: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested dicts flattened to dotted column names; lists become JSON text.

    Example:
        >>> flat({"gap_m": {"median": 0.1}, "bindings": 30, "path": [1, 2]})
        {'gap_m.median': 0.1, 'bindings': 30, 'path': '[1, 2]'}
    """
    row: dict[str, Any] = {}
    for key, value in table.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            row |= flat(value, f"{name}.")
        else:
            row[name] = json.dumps(value) if isinstance(value, list | tuple) else value
    return row
