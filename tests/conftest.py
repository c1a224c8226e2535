"""Fixtures shared by several test modules."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest


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
