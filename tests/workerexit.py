"""A pytest plugin (tests/conftest.py loads it): with pytest-xdist, each worker process exits
after the run, and a worker that crashes then (a segmentation fault at interpreter exit, as
issue 53 saw one run in nine do before the suite ran on workers) would leave the run green.
The controller reads each worker's exit status once they are down and fails the run on a
crash, naming the worker and the signal; a worker xdist itself killed for exiting slowly is
named, not failed."""

from __future__ import annotations

import signal
import sys
from collections.abc import Generator
from typing import Any

import pytest

#: The run's exit status when a worker crashed after it (pytest's "internal error").
WORKER_CRASHED = pytest.ExitCode.INTERNAL_ERROR


def _exit_status(gateway: Any) -> int | None:
    # execnet keeps a local worker's process as its gateway's io's ``popen``.
    popen = getattr(getattr(gateway, "_io", None), "popen", None)
    if popen is None:
        raise RuntimeError(f"cannot read the exit status of xdist worker {gateway.id}: "
                           "execnet keeps it elsewhere now (tests/workerexit.py)")
    return popen.returncode


def _described(code: int) -> str:
    return f"signal {signal.Signals(-code).name}" if code < 0 else f"status {code}"


@pytest.hookimpl(hookwrapper=True)
def pytest_sessionfinish(session: pytest.Session) -> Generator[None, None, None]:
    dsession = session.config.pluginmanager.getplugin("dsession")
    manager = getattr(dsession, "nodemanager", None)
    workers = list(manager.group) if manager is not None else []
    yield  # xdist's own hook stops the workers and waits for them
    statuses = {gateway.id: _exit_status(gateway) for gateway in workers}
    # xdist kills a worker still up after its exit timeout: slow (a loaded machine), no crash.
    stopped = [name for name, code in statuses.items() if code == -signal.SIGKILL]
    if stopped:
        sys.stderr.write("xdist stopped workers slow to exit (SIGKILL after its timeout): "
                         + ", ".join(stopped) + "\n")
    crashed = {name: code for name, code in statuses.items()
               if code not in (0, None, -signal.SIGKILL)}
    if crashed:
        sys.stderr.write("xdist workers exited badly after the run: " + ", ".join(
            f"{name} ({_described(code)})" for name, code in crashed.items()) + "\n")
        session.exitstatus = WORKER_CRASHED
