"""Where a batch diagnosis's replays run (docs/logs.md): side by side on worker processes of
this machine, each reading its log from the log's folder, or on a Ray cluster
(``diagnose-logs --address``), whose nodes need not share this machine's disk: the batch,
read once here, goes to the cluster's object store once, and each replay reads it there.

The pool that reaches a cluster is :class:`cell.scale.pool.RunPool` (the sweeps'); this
layer only names what it needs of it (:class:`ReplayPool`).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from types import TracebackType
from typing import Any, Protocol

import numpy as np

from cell.errors import DivergenceError, PoolError
from cell.logs.batch import LogBatch, log_scenario
from cell.logs.causes import changed_world
from cell.logs.fit import simulated_vector
from cell.logs.outcome import EVIDENCE_ROWS, evidence_misfits
from cell.measure.logs import SeparationLog, read_log
from cell.sim.scenario import Scenario

#: A world as a task carries it: the causes' magnitudes, sorted by cause.
Magnitudes = tuple[tuple[str, float], ...]


class Progress(Protocol):
    """What the replays report to: a :func:`cell.progress.progress_bar` (its ``total`` grows
    by each batch of replays planned, its description names the round)."""

    total: float | None

    def update(self, n: float = 1) -> bool | None:
        """``n`` replays done."""

    def set_description(self, desc: str | None = None, refresh: bool | None = True) -> None:
        """The round under way."""


class ReplayPool(Protocol):
    """What the replays need of a pool on a Ray cluster: :class:`cell.scale.pool.RunPool`,
    entered (its ``share`` and ``play``)."""

    def share(self, value: Any) -> Any:
        """``value`` sent once, for every task to read."""

    def play(self, function: Callable[..., Any], tasks: Sequence[Any], names: Sequence[str],
             shared: Any = None) -> Iterator[tuple[int, Any, str]]:
        """``function(shared value, task)`` on each task: ``(position, result, error)``."""


def _replayed(log: SeparationLog, scenario: Scenario, magnitudes: dict[str, float],
              started: float) -> tuple[np.ndarray | None, float]:
    """``log`` replayed in ``scenario`` changed by ``magnitudes``: its simulated vector (None
    where the physics blew up), its force channels then its misfits beyond them
    (:func:`~cell.logs.outcome.evidence_misfits`, unweighed), and the CPU time since
    ``started`` (``time.process_time``), s."""
    from cell.logs.replay import replay

    world = changed_world(scenario, magnitudes)
    try:
        result = replay(log, world)
    except DivergenceError:
        return None, time.process_time() - started
    vector = np.concatenate([simulated_vector(log, result.simulated),
                             evidence_misfits(log, result.simulated, result.released)])
    return vector, time.process_time() - started


def _replay_task(task: tuple[str, Magnitudes]) -> tuple[np.ndarray | None, float]:
    """One replay in a worker process here: the log in the folder ``task[0]`` in the world of
    the magnitudes ``task[1]`` (:func:`_replayed`)."""
    started = time.process_time()
    log = read_log(task[0])
    return _replayed(log, log_scenario(log), dict(task[1]), started)


def _replay_shipped(batch: LogBatch, task: tuple[int, Magnitudes]
                    ) -> tuple[np.ndarray | None, float]:
    """One replay on a cluster: log ``task[0]`` of ``batch`` (shipped from the driver) with its
    scenario, in the world of the magnitudes ``task[1]`` (:func:`_replayed`)."""
    started = time.process_time()
    index, magnitudes = task
    return _replayed(batch.logs[index], batch.scenarios[index], dict(magnitudes), started)


def _one_thread() -> None:
    # Replays run side by side, a core each: numeric libraries' own threads only compete.
    os.environ["OMP_NUM_THREADS"] = "1"


class Replayer:
    """Replays a batch's logs in changed worlds, side by side on ``workers`` processes (one:
    in this process) or, given ``cluster``, on that pool's Ray cluster; counting them, their
    wall time and their CPU time (the workers'). Each log's misfits beyond the forces come
    times :attr:`weight` (:func:`~cell.logs.outcome.evidence_weight`), and each entry times its
    log's :attr:`scales` (:mod:`cell.logs.chaos`).

    Example:
        >>> Replayer(LogBatch((), ()), 1).count
        0
    """

    def __init__(self, batch: LogBatch, workers: int, cluster: ReplayPool | None = None
                 ) -> None:
        self.batch = batch
        self.folders = [str(log.folder) for log in batch.logs]
        self.count, self.wall_s, self.cpu_s = 0, 0.0, 0.0
        #: The replays done by round (:attr:`round`): where a diagnosis's time went.
        self.by_round: dict[str, int] = {}
        #: The weight of the misfits beyond the forces (N a noise width).
        self.weight = 1.0
        #: Each log's factor on its vector's entries (:func:`~cell.logs.chaos.chaos_scales`),
        #: or None (1).
        self.scales: list[np.ndarray] | None = None
        #: The logs' sensor noise as a share of a batch's error (weighted RMS, N): what no
        #: replay can take away (:func:`~cell.logs.chaos.noise_variance`).
        self.noise_rmse_n = 0.0
        #: Where the replays done and planned show (a progress bar), or None.
        self.progress: Progress | None = None
        #: The round the replays are of (the progress bar's description).
        self.round = "screening"
        self._cluster = cluster
        self._shipped: Any = None
        #: Every replay done, unweighed, by log and world: a replay is a function of them.
        self._done: dict[tuple[int, Magnitudes], np.ndarray | None] = {}
        self._pool = (ProcessPoolExecutor(workers, mp_context=get_context("spawn"),
                                          initializer=_one_thread)
                      if workers > 1 and cluster is None else None)

    def __enter__(self) -> Replayer:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        if self._pool is not None:
            self._pool.shutdown(cancel_futures=True)

    def run(self, jobs: Sequence[tuple[int, dict[str, float]]]) -> list[np.ndarray | None]:
        """The simulated vectors of ``jobs`` (a log's index and the world's magnitudes); a job
        replayed before (the same log in the same world) is not replayed again.

        Raises:
            PoolError: on a cluster, a replay that came back without a result (its worker or
                node died, or it failed otherwise).
        """
        keys = [(i, tuple(sorted(m.items()))) for i, m in jobs]
        new = list(dict.fromkeys(key for key in keys if key not in self._done))
        self._planned(len(new))
        if self._cluster is not None:
            vectors = self._on_cluster(self._cluster, new)
        else:
            tasks = [(self.folders[i], magnitudes) for i, magnitudes in new]
            started = time.perf_counter()
            mapped = (self._pool.map(_replay_task, tasks) if self._pool is not None
                      else map(_replay_task, tasks))
            results = []
            for result in mapped:
                results.append(result)
                self._replayed()
            vectors = self._counted(results, started)
        self._done.update(zip(new, vectors, strict=True))
        return [None if self._done[key] is None else self.weighed(self._done[key], key[0])
                for key in keys]

    def _planned(self, jobs: int) -> None:
        if self.progress is not None:
            self.progress.total = (self.progress.total or 0) + jobs
            self.progress.set_description(self.round)

    def _replayed(self) -> None:
        if self.progress is not None:
            self.progress.update(1)

    def _on_cluster(self, cluster: ReplayPool, tasks: Sequence[tuple[int, Magnitudes]]
                    ) -> list[np.ndarray | None]:
        """:meth:`run` on ``cluster``; sending it the batch counts as replay time."""
        started = time.perf_counter()
        if self._shipped is None:
            self._shipped = cluster.share(self.batch)
        names = [f"replay-{self.count + k}-{self.batch.logs[i].name}"
                 for k, (i, _) in enumerate(tasks)]
        results: list[Any] = [None] * len(tasks)
        for position, result, error in cluster.play(_replay_shipped, tasks, names,
                                                    shared=self._shipped):
            if error:
                raise PoolError(None, "--address", f"{names[position]} gave no result: {error}")
            results[position] = result
            self._replayed()
        return self._counted(results, started)

    def _counted(self, results: list[tuple[np.ndarray | None, float]], started: float
                 ) -> list[np.ndarray | None]:
        """The vectors of ``results``, counted with their wall time since ``started`` and their
        CPU time."""
        self.count += len(results)
        self.by_round[self.round] = self.by_round.get(self.round, 0) + len(results)
        self.wall_s += time.perf_counter() - started
        self.cpu_s += sum(cpu for _, cpu in results)
        return [vector for vector, _ in results]

    def weighed(self, vector: np.ndarray, log: int) -> np.ndarray:
        """Log ``log``'s replayed vector times its :attr:`scales`, its misfits beyond the
        forces times :attr:`weight`."""
        out = vector.copy() if self.scales is None else vector * self.scales[log]
        out[-EVIDENCE_ROWS:] *= self.weight
        return out

    @property
    def in_process(self) -> bool:
        """Whether the replays run in this process (their CPU time is then this process's)."""
        return self._pool is None and self._cluster is None

    def batches(self, worlds: Sequence[dict[str, float]]) -> list[np.ndarray | None]:
        """Each world's simulated batch vector (every log replayed; None: one blew up)."""
        logs = range(len(self.folders))
        flat = self.run([(i, world) for world in worlds for i in logs])
        out = []
        for k in range(len(worlds)):
            parts = flat[k * len(logs):(k + 1) * len(logs)]
            out.append(None if any(p is None for p in parts) else np.concatenate(parts))
        return out
