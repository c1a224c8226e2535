"""Where a sweep's runs are played: one Ray task per run, on a Ray started here (one worker
per core by default) or on a cluster given by its address; or one after the other in this
process, without Ray, for debugging.

Ray is the ``scale`` extra: it is imported only when a pool uses it.
"""

from __future__ import annotations

import logging
import os
import re
import socket
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import Any, TypeVar

from cell.errors import SweepError

T = TypeVar("T")
R = TypeVar("R")
#: A cluster's address: its head's ``HOST:PORT`` or its client server's ``ray://HOST:PORT``.
_ADDRESS = re.compile(r"(?:ray://)?(?P<host>[A-Za-z0-9._\-]+|\[[0-9A-Fa-f:]+\])"
                      r":(?P<port>\d{1,5})")
#: How long a cluster's head may take to answer before the address counts as unreachable, s.
CONNECT_TIMEOUT_S = 5.0
#: What the CLI tells a user without Ray.
INSTALL_HINT = "pip install -e '.[scale]' (or --workers 1 runs without Ray, in this process)"


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
        cell.errors.SweepError: --workers: must be >= 1, got 0
    """

    count: int | None = None
    address: str | None = None
    ray: bool | None = None

    def __post_init__(self) -> None:
        if self.count is not None and self.count < 1:
            raise SweepError(None, "--workers", f"must be >= 1, got {self.count}")
        if self.ray is False and self.address is not None:
            raise SweepError(None, "--address", "a cluster is reached through Ray")
        if self.address is not None and self.address != "auto":
            match = _ADDRESS.fullmatch(self.address)
            if match is None or not 0 < int(match["port"]) < 65536:
                raise SweepError(None, "--address", f"not a Ray address: {self.address!r} "
                                 "(auto, HEAD_HOST:PORT or ray://HOST:PORT)")

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
    """

    def __init__(self, workers: Workers) -> None:
        self.workers = workers
        self.startup_s = 0.0
        self._ray: Any = None
        self._started_ray = False

    def __enter__(self) -> RunPool:
        if self.workers.in_process:
            return self
        started = time.perf_counter()
        self._ray = require_ray("--address" if self.workers.address else "--workers")
        if not self._ray.is_initialized():
            _reachable(self.workers.address)
            try:
                self._ray.init(**self._init_options())
            except (ConnectionError, TimeoutError, RuntimeError, ValueError) as exc:
                raise SweepError(None, "--address" if self.workers.address else "--workers",
                                 f"cannot start or join Ray: {exc}") from None
            self._started_ray = True
        self.startup_s = time.perf_counter() - started
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        if self._started_ray:
            self._ray.shutdown()

    def _init_options(self) -> dict[str, Any]:
        # Workers render the camera headless, as `musclecell run` does.
        options: dict[str, Any] = {
            "runtime_env": {"env_vars": {"MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}},
            "log_to_driver": False, "logging_level": logging.WARNING}
        if self.workers.address is not None:
            return {**options, "address": self.workers.address}
        # "local": a Ray of its own, even where `ray start` left one running on this machine.
        return {**options, "address": "local",
                "num_cpus": self.workers.count or os.cpu_count() or 1,
                "include_dashboard": False}

    def play(self, function: Callable[[T], R], tasks: Sequence[T], names: Sequence[str]
             ) -> Iterator[tuple[int, R | None, str]]:
        """``function`` on each task; yields ``(position, result, error)`` as tasks finish:
        ``error`` is empty, or says why a task gave no result (its worker or node died).
        ``names`` name the tasks in Ray (and in the workers' process titles)."""
        if self._ray is None:
            for position, task in enumerate(tasks):
                yield position, function(task), ""
            return
        ray = self._ray
        remote = ray.remote(num_cpus=1, max_retries=0)(function)
        limit = self.workers.count or len(tasks)  # a cluster's own CPUs bound it otherwise
        waiting = iter(range(len(tasks)))
        pending: dict[Any, int] = {}

        def submit() -> None:
            position = next(waiting, None)
            if position is not None:
                ref = remote.options(name=names[position]).remote(tasks[position])
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


def _reachable(address: str | None) -> None:
    """Fail within :data:`CONNECT_TIMEOUT_S` where a ``HOST:PORT`` address does not answer:
    Ray itself keeps trying for a minute or more.

    Raises:
        SweepError: naming ``--address`` and what the connection said.
    """
    match = None if address is None else _ADDRESS.fullmatch(address)
    if match is None:
        return
    host = match["host"].strip("[]")
    try:
        socket.create_connection((host, int(match["port"])), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        raise SweepError(None, "--address", f"cannot reach {address}: "
                         f"{exc.strerror or exc or 'no answer'}") from None


def require_ray(option: str) -> Any:
    """The ``ray`` module, or a :class:`SweepError` on ``option`` that says how to install it.

    Usage statistics are off unless the user turned them on: a sweep does not report to
    anyone, and CI machines have no network.
    """
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    try:
        import ray
    except ImportError:
        raise SweepError(None, option, f"Ray is not installed: {INSTALL_HINT}") from None
    return ray
