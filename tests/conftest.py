"""Fixtures shared by several test modules."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from cell.cores import WORKERS_VARIABLE

#: A worker that crashes at its exit fails the run (tests/workerexit.py).
pytest_plugins = ["tests.workerexit"]

# The run already keeps every core busy (one test process per core): a diagnosis or an
# evaluation that started a pool of its own would add only processes and their start-up.
# A test of the pools passes its worker count.
os.environ.setdefault(WORKERS_VARIABLE, "1")


@pytest.fixture
def cluster(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Iterator[str]:
    """A Ray cluster of two nodes of one CPU each on this machine (:mod:`tests.raycluster`);
    yields the head's address.

    Without token authentication: a Ray driver settles its authentication once per process
    (this one has already started a local Ray, or imported ray before this fixture), and the
    cluster only listens on this machine for the test's length.
    """
    pytest.importorskip("ray")
    from tests.raycluster import ray_cluster

    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")
    with ray_cluster(tmp_path) as address:
        yield address
