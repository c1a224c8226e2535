"""`musclecell sweep` on Ray: on a local Ray with two workers, one of which is killed in the
middle of a run, and on a two-node cluster started here and reached through `--address`, as
a user with a cluster would."""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import psutil
import pyarrow.parquet as pq
import pytest

from cell.cli import main
from cell.scale.runs import TIMING_COLUMNS
from tests.paths import DEFAULT_SCENARIO

pytest.importorskip("ray")

SWEEP = f"""
[sweep]
scenario = "{DEFAULT_SCENARIO.as_posix()}"
seed = 11

[overrides]
tissue.cell_size_m = 0.05
perception.enabled = false

[variables]
end_s = [0.3, 3.0]
# A tissue speed limit no run can keep: that run diverges at its first step.
simulation.max_tissue_speed_m_s = [20.0, 1e-4]
"""
#: The run whose worker is killed: a 3 s episode, the others end within a second.
KILLED = "run-0002"


@pytest.fixture(autouse=True)
def _quiet_ray(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("RAY_USAGE_STATS_ENABLED", "0")


def _table(folder: Path) -> list[dict]:
    return pq.read_table(folder / "results.parquet").to_pylist()


def _without_timing(row: dict) -> dict:
    # A column only another run has (the knife's force split of a run that reached the cut)
    # is None in this row: as good as absent from a table without that run.
    return {k: v for k, v in row.items() if k not in TIMING_COLUMNS and v is not None}


def _kill_when_running(title: str, killed: list[int], stop: threading.Event) -> None:
    """SIGKILL the Ray worker whose process title is ``title`` once it shows up."""
    while not stop.is_set():
        for process in psutil.process_iter(["cmdline"]):
            if (process.info["cmdline"] or [""])[0].startswith(f"ray::{title}"):
                time.sleep(0.05)  # midway: the episode is being built (the implicit step runs
                # the whole 3 s episode in well under half a second)
                os.kill(process.pid, signal.SIGKILL)
                killed.append(process.pid)
                return
        time.sleep(0.02)


@pytest.mark.slow
def test_a_killed_worker_fails_its_run_and_the_others_match_a_sweep_without_ray(
        tmp_path: Path) -> None:
    path = tmp_path / "sweep.toml"
    path.write_text(SWEEP)
    killed: list[int] = []
    stop = threading.Event()
    killer = threading.Thread(target=_kill_when_running, args=(KILLED, killed, stop))
    killer.start()
    try:
        code = main(["sweep", str(path), "--out", str(tmp_path / "ray"), "--workers", "2",
                     "--quiet"])
    finally:
        stop.set()
        killer.join()
    assert code == 4 and killed  # a failed run: the table is written, the exit says so
    on_ray = _table(tmp_path / "ray")
    assert [row["status"] for row in on_ray] == ["ok", "diverged", "failed", "diverged"]
    assert "WorkerCrashedError" in on_ray[2]["error"]
    assert on_ray[0]["sim_time_s"] == pytest.approx(0.3, abs=0.02)

    assert main(["sweep", str(path), "--out", str(tmp_path / "plain"), "--workers", "1",
                 "--quiet"]) == 0
    plain = _table(tmp_path / "plain")
    assert plain[2]["status"] == "ok"
    for k in (0, 1, 3):
        assert _without_timing(on_ray[k]) == _without_timing(plain[k])


@pytest.mark.slow  # a two-node cluster started here
def test_a_sweep_runs_on_a_cluster_given_its_address(cluster: str, tmp_path: Path,
                                                     capsys: pytest.CaptureFixture) -> None:
    path = tmp_path / "sweep.toml"
    path.write_text(SWEEP.replace("end_s = [0.3, 3.0]", "end_s = [0.3, 0.4]"))
    assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--address", cluster,
                 "--quiet"]) == 0
    assert "4 runs (4 played now, 0 found finished" in capsys.readouterr().out
    rows = _table(tmp_path / "out")
    assert [row["status"] for row in rows] == ["ok", "diverged", "ok", "diverged"]
    assert [row["sim_time_s"] for row in rows[::2]] == pytest.approx([0.3, 0.4], abs=0.02)
