"""Where many runs are played (a sweep's runs, a batch's sets, a log diagnosis's replays on
a cluster): one Ray task per run, on a Ray started here (one worker per core by default) or
on a cluster given by its address; or one after the other in this process, without Ray, for
debugging.

Ray is the ``scale`` extra: it is imported only when a pool uses it.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import ExitStack
from dataclasses import dataclass
from types import TracebackType
from typing import Any, TypeVar

from cell.errors import PoolError
from cell.rayconnect import check_address, ray_session

T = TypeVar("T")
R = TypeVar("R")


@dataclass(frozen=True)
class Workers:
    """How many runs go side by side, and where.

    Attributes:
        count: runs at a time (None: one per core of this machine, or every CPU of the
            cluster); 1 without an address plays them in this process, without Ray.
        address: a Ray cluster to join (``auto``, ``HOST:PORT`` of its head, or
            ``ray://HOST:PORT`` of its client server); None starts Ray here.
        ray: play on Ray or not; None: on Ray unless ``count`` is 1 and there is no
            address (one worker on Ray measures what Ray costs).

    Example:
        >>> Workers(1).in_process, Workers(2).in_process
        (True, False)
        >>> Workers(0)
        Traceback (most recent call last):
        cell.errors.PoolError: --workers: must be >= 1, got 0
    """

    count: int | None = None
    address: str | None = None
    ray: bool | None = None

    def __post_init__(self) -> None:
        if self.count is not None and self.count < 1:
            raise PoolError(None, "--workers", f"must be >= 1, got {self.count}")
        if self.ray is False and self.address is not None:
            raise PoolError(None, "--address", "a cluster is reached through Ray")
        if self.address is not None:
            check_address(self.address, "--address")

    @property
    def in_process(self) -> bool:
        """Played here, one after the other, without Ray."""
        if self.ray is not None:
            return not self.ray
        return self.count == 1 and self.address is None


class RunPool:
    """Plays tasks with :class:`Workers`: a context manager that starts (or joins) Ray on
    entry and stops (or leaves) it on exit; ``startup_s`` is how long that took, s.

    Example:
        >>> with RunPool(Workers(1)) as pool:
        ...     sorted(pool.play(abs, [-2, 3], ["a", "b"]))
        [(0, 2, ''), (1, 3, '')]
        >>> with RunPool(Workers(1)) as pool:
        ...     sorted(pool.play(pow, [2, 3], ["a", "b"], shared=pool.share(10)))
        [(0, 100, ''), (1, 1000, '')]
    """

    def __init__(self, workers: Workers) -> None:
        self.workers = workers
        self.startup_s = 0.0
        self._ray: Any = None
        self._session = ExitStack()

    def __enter__(self) -> RunPool:
        if self.workers.in_process:
            return self
        started = time.perf_counter()
        self._ray = self._session.enter_context(ray_session(
            self.workers.address, "--address" if self.workers.address else "--workers",
            cpus=self.workers.count))
        self.startup_s = time.perf_counter() - started
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        self._session.close()

    def share(self, value: Any) -> Any:
        """``value``, an input every task reads, ready for :meth:`play`'s ``shared``: on Ray,
        put in its object store once (each node fetches it once, from this machine: a
        cluster's nodes need not share its disk), else ``value`` itself."""
        return value if self._ray is None else self._ray.put(value)

    def play(self, function: Callable[..., R], tasks: Sequence[T], names: Sequence[str],
             shared: Any = None) -> Iterator[tuple[int, R | None, str]]:
        """``function`` on each task; yields ``(position, result, error)`` as tasks finish:
        ``error`` is empty, or says why a task gave no result (its worker or node died).
        ``names`` name the tasks in Ray (and in the workers' process titles). With ``shared``
        (from :meth:`share`), each call is ``function(value, task)``, ``value`` the one
        shared."""
        first = () if shared is None else (shared,)
        if self._ray is None:
            for position, task in enumerate(tasks):
                yield position, function(*first, task), ""
            return
        ray = self._ray
        remote = ray.remote(num_cpus=1, max_retries=0)(function)
        limit = self.workers.count or len(tasks)  # a cluster's own CPUs bound it otherwise
        waiting = iter(range(len(tasks)))
        pending: dict[Any, int] = {}

        def submit() -> None:
            position = next(waiting, None)
            if position is not None:
                # Ray hands a task the value of an object reference passed as an argument.
                ref = remote.options(name=names[position]).remote(*first, tasks[position])
                pending[ref] = position

        for _ in range(min(limit, len(tasks))):
            submit()
        while pending:
            (ref,), _ = ray.wait(list(pending), num_returns=1)
            position = pending.pop(ref)
            submit()
            try:
                yield position, ray.get(ref), ""
            except ray.exceptions.RayError as exc:
                yield position, None, f"{type(exc).__name__}: {str(exc).strip().splitlines()[0]}"
