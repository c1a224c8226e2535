"""The loop that sweeps and batches share: find the runs a results folder already holds, play
the others on a :class:`~cell.scale.pool.RunPool`, keep each one's record as it finishes.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from cell.progress import progress_bar
from cell.scale.pool import RunPool, Workers
from cell.scale.store import ResultsFolder

T = TypeVar("T")
R = TypeVar("R")


@dataclass(frozen=True)
class Played:
    """Every run's row (in the runs' order), how many were played now, how long it took to
    start or join Ray and to play them (that start included), s."""

    rows: list[dict[str, Any]]
    played: int
    startup_s: float
    play_s: float


def play_missing(function: Callable[[T], R], tasks: Sequence[T], names: Sequence[str],
                 prints: Sequence[str], results: ResultsFolder, workers: Workers, *,
                 keep: Callable[[str, R | None, str], dict[str, Any]],
                 retry_failed: bool = False, progress: bool = True, desc: str = ""
                 ) -> Played:
    """Play the tasks whose record in ``results`` is missing or has another fingerprint
    (``prints``; with ``retry_failed``, those whose status is not ``ok`` too).

    ``keep(name, result, error)`` turns a finished task (its ``result``, or None and the
    ``error`` that says why its worker gave none) into its record, a dict with its ``row``,
    which is saved with the task's fingerprint before the next task is taken.
    """
    records = results.finished()
    rows: dict[int, dict[str, Any]] = {}
    for k, name in enumerate(names):
        record = records.get(name)
        if (record is not None and record.get("fingerprint") == prints[k]
                and (record["row"].get("status") == "ok" or not retry_failed)):
            rows[k] = record["row"]
    todo = [k for k in range(len(tasks)) if k not in rows]
    started = time.perf_counter()
    # Nothing to play: no Ray to start.
    with (RunPool(workers if todo else Workers(1)) as pool,
          progress_bar("run", quiet=not progress, total=len(tasks), initial=len(rows),
                       desc=desc) as bar):
        for position, result, error in pool.play(function, [tasks[k] for k in todo],
                                                 [names[k] for k in todo]):
            k = todo[position]
            record = keep(names[k], result, error)
            results.save(names[k], {"fingerprint": prints[k], **record})
            rows[k] = record["row"]
            bar.update()
        play_s = time.perf_counter() - started
    return Played([rows[k] for k in range(len(tasks))], len(todo), pool.startup_s, play_s)
