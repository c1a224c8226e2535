"""A Ray cluster of two nodes started on this machine for a test (the ``cluster`` fixture
of tests/conftest.py): the sweeps' and the log diagnosis's tests on a cluster reach it through
its address, as a user with a cluster would."""

from __future__ import annotations

import contextlib
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import psutil

_STARTUP_TIMEOUT_S = 120.0


@contextlib.contextmanager
def ray_cluster(tmp_path: Path) -> Iterator[str]:
    """Two nodes of one CPU each; yields the head's address, stops them after (their logs
    in ``tmp_path``)."""
    ray = Path(sys.executable).with_name("ray")
    port = _free_port()
    address = f"127.0.0.1:{port}"
    def common() -> list[str]:  # each node's agents on ports of their own
        return ["--num-cpus=1", "--object-store-memory=100000000", "--disable-usage-stats",
                "--block", f"--dashboard-agent-listen-port={_free_port()}",
                f"--metrics-export-port={_free_port()}"]

    logs = (tmp_path / "ray-head.log").open("w"), (tmp_path / "ray-node.log").open("w")
    processes = [subprocess.Popen(
        [str(ray), "start", "--head", f"--port={port}", "--include-dashboard=false",
         f"--ray-client-server-port={_free_port()}", *common()],
        stdout=logs[0], stderr=subprocess.STDOUT)]
    try:
        _wait_for(lambda: _accepts(port), "the head")
        processes.append(subprocess.Popen([str(ray), "start", f"--address={address}", *common()],
                                          stdout=logs[1], stderr=subprocess.STDOUT))
        _wait_for(lambda: _alive_nodes(address) == 2, "the second node")
        yield address
    finally:
        _stop(processes)
        for log in logs:
            log.close()


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _stop(processes: list[subprocess.Popen]) -> None:
    """Stop the `ray start --block` processes, the joining node first, and whatever they
    started that outlives them."""
    descendants = [child for process in processes if process.poll() is None
                   for child in psutil.Process(process.pid).children(recursive=True)]
    for process in reversed(processes):
        process.terminate()
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
    for child in descendants:
        with contextlib.suppress(psutil.NoSuchProcess):
            child.kill()


def _accepts(port: int) -> bool:
    try:
        socket.create_connection(("127.0.0.1", port), timeout=1).close()
        return True
    except OSError:
        return False


def _alive_nodes(address: str) -> int:
    import ray

    try:
        ray.init(address=address, logging_level="WARNING", log_to_driver=False)
    except ConnectionError:  # the head's services are not all up yet
        return 0
    try:
        return sum(node["Alive"] for node in ray.nodes())
    finally:
        ray.shutdown()


def _wait_for(ready: object, what: str) -> None:
    deadline = time.monotonic() + _STARTUP_TIMEOUT_S
    while not ready():
        if time.monotonic() > deadline:
            raise TimeoutError(f"{what} of the test cluster did not start")
        time.sleep(0.2)
