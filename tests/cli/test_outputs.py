"""Outputs first: every command checks where it writes before any work, refuses with exit 2
and a message naming the path and the option, and leaves the output and working folders as
they were; a stopped command (Ctrl-C, SIGTERM) leaves no temporary file and resumes cleanly.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cell.bench.command import DEFAULT_SCENARIO as BENCH_SCENARIO
from cell.cli import main
from cell.errors import LearningError, OutputError
from cell.outputs import Output, check_outputs
from tests.interactive import CTRL_C_RAISES
from tests.paths import DEFAULT_SCENARIO, EXAMPLE_SET, PROJECT_ROOT
from tests.refusals import refused, snapshot

#: A short run on coarse tissue: seconds, with a recording.
SHORT = ('[scenario]\nname = "short"\nend_s = 1.5\n[tissue]\ncell_size_m = 0.05\n'
         "[recording]\nrate_hz = 10.0\ncamera_rate_hz = 2.0\n")
#: A run whose binding springs are so stiff that MuJoCo's accelerations blow up at once
#: (the tissue's own speed limit lifted, so MuJoCo's warning is what stops it).
DIVERGING = ('[scenario]\nname = "diverging"\nend_s = 0.3\n[tissue]\ncell_size_m = 0.05\n'
             "[perception]\nenabled = false\n[aponeurosis]\nstiffness_n_m = 1e15\n"
             "[simulation]\nmax_tissue_speed_m_s = 1e300\n")


@pytest.fixture
def place(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A working folder (the current one) holding a short scenario, a folder ``taken`` and a
    file ``plain.txt``."""
    work = tmp_path / "work"
    work.mkdir()
    (work / "short.toml").write_text(SHORT)
    (work / "taken").mkdir()
    (work / "plain.txt").write_text("a file\n")
    monkeypatch.chdir(work)
    return work


@pytest.mark.parametrize(("argv", "named"), [
    (["run", "short.toml", "--rerun", "taken", "--quiet"], ["taken", "--rerun", "folder"]),
    (["run", "short.toml", "--rerun", "ok.rrd", "--out", "plain.txt/x.json", "--quiet"],
     ["plain.txt", "--out", "not a folder"]),
    (["run", "short.toml", "--out", "short.toml", "--quiet"], ["short.toml", "--out"]),
    (["plan", "short.toml", "--out", "taken"], ["taken", "--out"]),
    (["export-mjcf", "short.toml", "--out", "taken"], ["taken", "--out"]),
    (["export-mjcf", "short.toml", "-o", "short.toml"], ["short.toml", "--out", "input"]),
    (["export-mjcf", "short.toml", "./short.toml"], ["short.toml", "OUTPUT", "input"]),
    (["render", "short.toml", "--out", "taken"], ["taken", "--out"]),
    (["render", "short.toml", "--out", "a.png", "--width", "0"], ["--width"]),
    (["diagnose", str(EXAMPLE_SET), "--out", "taken"], ["taken", "--out"]),
    (["diagnose", str(EXAMPLE_SET), "--out", "d.json", "--report", "plain.txt"],
     ["plain.txt", "--report", "is a file"]),
    (["diagnose", str(EXAMPLE_SET), "--out", "d.json", "--material", "d.json"],
     ["d.json", "--material"]),
    (["diagnose", str(EXAMPLE_SET), "--out", str(EXAMPLE_SET / "tests.csv")],
     ["tests.csv", "--out", "input"]),
    (["learn", "Cut-v3", "--steps", "10", "--out", "plain.txt"], ["plain.txt", "--out"]),
    (["bench", "--out", "taken"], ["taken", "--out"]),
    (["bench", "perception", "--shapes", "-2"], ["--shapes", ">= 0"]),
    (["bench", "tissue", "--quick", "--markdown", "taken"], ["taken", "--markdown"]),
    (["sweep", str(PROJECT_ROOT / "scenarios" / "sweeps" / "binding_strength.toml"),
      "--out", "plain.txt", "--workers", "1"], ["plain.txt", "--out", "is a file"]),
    (["sweep", str(PROJECT_ROOT / "scenarios" / "sweeps" / "binding_strength.toml"),
      "--out", "results", "--address", "nonsense"], ["--address", "nonsense"]),
])
def test_a_bad_output_is_refused_before_any_work(argv: list[str], named: list[str],
                                                 place: Path) -> None:
    refused(place, *argv, words=tuple(named))


def test_an_unreachable_cluster_fails_within_seconds(place: Path) -> None:
    pytest.importorskip("ray")
    sweep = PROJECT_ROOT / "scenarios" / "sweeps" / "binding_strength.toml"
    started = time.perf_counter()
    refused(place, "sweep", str(sweep), "--out", "results", "--address", "127.0.0.1:1",
            words=("--address", "cannot reach"))
    assert time.perf_counter() - started < 30.0


def test_bench_finds_its_default_scenario_from_any_folder(place: Path) -> None:
    assert BENCH_SCENARIO.samefile(DEFAULT_SCENARIO)
    # Refused on its output, after the scenario was found: no work done.
    message = refused(place, "bench", "perception", "--out", "taken", words=("--out",))
    assert "--scenario" not in message


def test_a_policy_path_that_is_not_policy_zip_is_named(place: Path) -> None:
    pytest.importorskip("stable_baselines3")
    (place / "junk.zip").write_text("not a zip")
    refused(place, "evaluate", "junk.zip", "musclecell/Cut-v3", words=("junk.zip",))


def test_a_corrupt_policy_zip_is_a_named_error(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    from cell.learning.convert import load_saved_policy

    broken = tmp_path / "policy.zip"
    broken.write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.raises(LearningError, match=r"policy\.zip"):
        load_saved_policy(broken)


def test_two_outputs_on_one_file_are_refused(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="--summary"):
        check_outputs([Output(tmp_path / "a.json", "--json"),
                       Output(tmp_path / "a.json", "--summary")])


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes anywhere")
def test_a_read_only_folder_is_refused(tmp_path: Path) -> None:
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    with pytest.raises(OutputError, match="cannot write"):
        check_outputs([Output(locked / "new" / "a.json", "--json")])


def test_render_writes_a_picture_of_the_asked_size(place: Path) -> None:
    assert main(["render", str(DEFAULT_SCENARIO), "--out", "cell.png", "--width", "160",
                 "--height", "90"]) == 0
    png = (place / "cell.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
    assert (width, height) == (160, 90)
    import io

    import numpy as np
    from PIL import Image

    rows = np.asarray(Image.open(io.BytesIO(png)))
    assert rows.std() > 10.0, "a blank picture"
    assert not list(place.glob(".*.tmp"))


def test_a_diverged_run_exits_3_and_writes_no_mujoco_log(place: Path,
                                                         capsys: pytest.CaptureFixture) -> None:
    (place / "diverging.toml").write_text(DIVERGING)
    before = snapshot(place)
    assert main(["run", "diverging.toml", "--rerun", "new/d.rrd", "--out", "new/s.json",
                 "--quiet"]) == 3
    message = capsys.readouterr().err
    assert "diverged" in message and "Traceback" not in message
    assert snapshot(place) == before  # no MUJOCO_LOG.TXT, no recording, no folder new/


def _stop_when(process: subprocess.Popen, ready: callable, number: int,
               timeout_s: float = 120.0) -> tuple[int, str]:
    """Send signal ``number`` once ``ready()`` holds; the exit code and stderr."""
    deadline = time.monotonic() + timeout_s
    while not ready():
        assert process.poll() is None, process.communicate()[1]
        assert time.monotonic() < deadline, "the command never got going"
        time.sleep(0.05)
    process.send_signal(number)
    _, err = process.communicate(timeout=60)
    return process.returncode, err


def _musclecell(argv: list[str], cwd: Path) -> subprocess.Popen:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
           "PYTHONPATH": str(PROJECT_ROOT)}
    return subprocess.Popen([sys.executable, "-c", CTRL_C_RAISES + "import sys; from cell.cli "
                             "import main; sys.exit(main(sys.argv[1:]))", *argv], cwd=cwd, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


@pytest.mark.parametrize(("number", "code", "recorded_bytes"), [
    (signal.SIGINT, 130, 0),
    pytest.param(signal.SIGTERM, 143, 200_000, marks=pytest.mark.slow),
    pytest.param(signal.SIGTERM, 143, 0, marks=pytest.mark.slow),
    pytest.param(signal.SIGINT, 130, 200_000, marks=pytest.mark.slow)])
def test_a_stopped_recording_leaves_no_temporary_file(place: Path, number: int, code: int,
                                                      recorded_bytes: int) -> None:
    """Stopped as the recording starts, and in the middle of the episode."""
    (place / "long.toml").write_text(SHORT.replace("end_s = 1.5", "end_s = 8.0"))
    process = _musclecell(["run", "long.toml", "--rerun", "out/long.rrd", "--out",
                           "out/s.json", "--quiet"], place)

    def recording() -> bool:
        sizes = [os.stat(p).st_size if p.exists() else -1
                 for p in (place / "out").glob(".long.rrd.*.tmp")]
        return any(size >= recorded_bytes for size in sizes)

    rc, err = _stop_when(process, recording, number)
    assert rc == code, err
    assert "Traceback" not in err and ("stopped" in err or "interrupted" in err)
    assert not (place / "out").exists()  # made for the recording, taken back with it


#: A sweep of four short runs, one at a time in this process.
SWEEP = f"""
[sweep]
scenario = "{DEFAULT_SCENARIO.as_posix()}"
seed = 5

[overrides]
tissue.cell_size_m = 0.05
perception.enabled = false
end_s = 0.3

[variables]
aponeurosis.stiffness_n_m = [40.0, 60.0, 80.0, 100.0]
"""


@pytest.mark.slow
@pytest.mark.parametrize("number", [signal.SIGINT, signal.SIGTERM])
def test_a_stopped_sweep_leaves_no_temporary_file_and_resumes(place: Path,
                                                              number: int) -> None:
    (place / "sweep.toml").write_text(SWEEP)
    argv = ["sweep", "sweep.toml", "--out", "results", "--workers", "1", "--quiet"]
    runs = place / "results" / "runs"
    rc, err = _stop_when(_musclecell(argv, place),
                         lambda: runs.is_dir() and any(runs.glob("*.json")), number)
    assert rc == 128 + number, err
    assert "Traceback" not in err
    assert not [p for p in (place / "results").rglob("*") if p.name.endswith(".tmp")]
    finished = len(list(runs.glob("*.json")))
    assert 1 <= finished < 4
    resumed = subprocess.run([sys.executable, "-m", "cell.cli", *argv], cwd=place, text=True,
                             capture_output=True, check=False,
                             env={**os.environ, "PYTHONPATH": str(PROJECT_ROOT)})
    assert resumed.returncode == 0, resumed.stderr
    assert f"{4 - finished} played now, {finished} found finished" in resumed.stdout


@pytest.mark.slow
@pytest.mark.parametrize("number", [signal.SIGINT, signal.SIGTERM])
def test_a_stopped_learn_leaves_no_temporary_file_and_resumes(place: Path,
                                                              number: int) -> None:
    pytest.importorskip("stable_baselines3")
    import json

    short = json.dumps({"time_limit_s": 0.2, "cell_size_m": 0.08,
                        "options": {"tissue": {"length_m": 0.3}}})
    hyper = json.dumps({"n_steps": 16, "batch_size": 16, "n_epochs": 2})
    learn = ["learn", "musclecell/Cut-v1", "--envs", "1", "--checkpoint-every", "16",
             "--out", "run"]
    states = place / "run" / "checkpoints"
    rc, err = _stop_when(
        _musclecell([*learn, "--steps", "100000", "--env-kwargs", short, "--hyper", hyper],
                    place),
        lambda: states.is_dir() and any(states.glob("*/state.json")), number, 300.0)
    assert rc == 128 + number, err
    assert "Traceback" not in err
    assert not [p for p in (place / "run").rglob("*") if p.name.endswith(".tmp")]
    done = max(int(p.parent.name.split("_")[1]) for p in states.glob("*/state.json"))
    resumed = subprocess.run(
        [sys.executable, "-m", "cell.cli", *learn, "--steps", str(done + 16), "--resume"],
        cwd=place, text=True, capture_output=True, check=False,
        env={**os.environ, "PYTHONPATH": str(PROJECT_ROOT)})
    assert resumed.returncode == 0, resumed.stderr
    assert json.loads((place / "run" / "learn.json").read_text())["steps"] >= done + 16
