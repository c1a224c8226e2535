"""A worker of the parallel test run that crashes at its exit fails the run
(tests/workerexit.py), where pytest-xdist alone reports it green."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.paths import PROJECT_ROOT

CRASHES_AT_EXIT = """
import atexit, os, signal

def test_that_leaves_a_crash_for_the_exit():
    atexit.register(lambda: os.kill(os.getpid(), signal.SIGSEGV))

def test_beside_it():
    pass
"""


def _run(folder: Path, source: str) -> subprocess.CompletedProcess[str]:
    (folder / "test_exit_case.py").write_text(source)
    return subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-n", "2", "-p", "no:cacheprovider",
         "-p", "tests.workerexit", "--rootdir", str(folder), str(folder)],
        cwd=folder, capture_output=True, text=True, check=False,
        env={**os.environ, "PYTHONPATH": str(PROJECT_ROOT)})


def test_a_worker_that_crashes_at_its_exit_fails_the_run(tmp_path: Path) -> None:
    done = _run(tmp_path, CRASHES_AT_EXIT)
    assert "2 passed" in done.stdout
    assert done.returncode != 0
    assert "exited badly after the run" in done.stderr and "SIGSEGV" in done.stderr


def test_workers_that_exit_cleanly_leave_the_run_green(tmp_path: Path) -> None:
    done = _run(tmp_path, "def test_one():\n    pass\n\ndef test_two():\n    pass\n")
    assert done.returncode == 0, done.stderr


SLOW_TO_EXIT = """
import atexit, time

def test_that_leaves_a_slow_exit():
    atexit.register(lambda: time.sleep(60))
"""


@pytest.mark.slow  # xdist waits out its exit timeout
def test_a_worker_that_xdist_stops_for_exiting_slowly_is_named_not_failed(
        tmp_path: Path) -> None:
    done = _run(tmp_path, SLOW_TO_EXIT)
    assert done.returncode == 0, done.stderr
    assert "slow to exit" in done.stderr
