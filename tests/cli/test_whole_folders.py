"""Output folders appear whole or not at all: ``diagnose --report``, ``diagnose-logs --out``,
``replay --out`` and ``run --log`` fill a temporary folder beside theirs and rename it into
place. A writer stopped (Ctrl-C) or failing midway leaves no folder and no temporary one, and
a folder that was there keeps exactly what it had.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from cell.cli import main
from cell.errors import Stopped
from cell.folders import AtomicFolder, write_files_and_folders, write_folder
from cell.outputs import write_atomic
from tests.interactive import CTRL_C_RAISES
from tests.paths import EXAMPLE_SET, PROJECT_ROOT

WRITTEN = "written before the stop\n"
OLD = "from the run before\n"


def old_output(work: Path, mark: str = "old.txt") -> dict[str, str]:
    """The folder ``out`` of a run before, in ``work``, holding the file ``mark`` (what the
    command writes, so that it may replace the folder); what the working folder holds then."""
    (work / "out").mkdir()
    (work / "out" / mark).write_text(OLD)
    return {"out": "dir", f"out/{mark}": OLD}


def listing(folder: Path) -> dict[str, str]:
    """Every file and folder under ``folder`` (hidden ones too), with each file's text."""
    return {str(p.relative_to(folder)): p.read_text() if p.is_file() else "dir"
            for p in sorted(folder.rglob("*"))}


def half_writer(raised: BaseException | None, after: int = 0) -> Callable[..., Any]:
    """A writer that writes a file into the folder it is given, and raises ``raised`` (if
    any) on its call number ``after`` (from 0): stopped or failing midway."""
    calls = []

    def write(*args: Any, **kwargs: Any) -> None:
        folder = next(a for a in args if isinstance(a, Path))
        write_atomic(folder / "first.txt", WRITTEN)
        calls.append(folder)
        if raised is not None and len(calls) > after:
            raise raised

    return write


class FakeSetDiagnosis:
    """What ``diagnose`` reads of a diagnosis, found in no time."""
    causes: tuple[str, ...] = ()
    uniaxial = None

    def to_json(self) -> dict[str, Any]:
        return {"causes": []}

    def material(self) -> None:
        return None

    def material_comment(self) -> str:
        return ""

    def summary(self) -> str:
        return "nothing found"


def _diagnose(monkeypatch: pytest.MonkeyPatch, writer: Callable[..., Any]) -> list[str]:
    monkeypatch.setattr("cell.diagnosis.sets.diagnose_set",
                        lambda measurements, params, on_fit: FakeSetDiagnosis())
    monkeypatch.setattr("cell.tissue.materialfile.material_to_toml",
                        lambda material, comment: "# material\n")
    monkeypatch.setattr("cell.diagnosis.cut.report.write_set_report", writer)
    return ["diagnose", str(EXAMPLE_SET), "--out", "d.json", "--report", "out"]


def _diagnose_logs(monkeypatch: pytest.MonkeyPatch, writer: Callable[..., Any]) -> list[str]:
    monkeypatch.setattr("cell.logs.batch.read_log_batch", lambda logs: None)
    data = {"causes": [], "baseline": {"heldout_rmse_N": 1.0}, "gain": 0.0,
            "extended": {"heldout_rmse_N": 1.0}, "timing": {"replays": 0, "total_s": 0.0}}
    monkeypatch.setattr("cell.logs.diagnosis.diagnose_logs",
                        lambda *args: SimpleNamespace(to_json=lambda: data))
    monkeypatch.setattr("cell.logs.report.write_log_diagnosis", writer)
    return ["diagnose-logs", "log-a", "log-b", "--out", "out", "--no-plots"]


def _replay(monkeypatch: pytest.MonkeyPatch, writer: Callable[..., Any]) -> list[str]:
    logs = tuple(SimpleNamespace(folder=Path(name)) for name in ("log-a", "log-b"))
    summary = {"log": "log", "rmse_share": {}, "bindings": 0,
               "counts": {"released": {"replayed": 0, "logged": 0},
                          "torn": {"replayed": 0, "logged": 0}}}
    monkeypatch.setattr("cell.logs.batch.read_log_batch",
                        lambda paths: SimpleNamespace(logs=logs))
    monkeypatch.setattr("cell.logs.replay.replay",
                        lambda log, progress: SimpleNamespace(summary=lambda: summary))
    monkeypatch.setattr("cell.logs.replay.write_replay", writer)
    return ["replay", "log-a", "log-b", "--out", "out"]


class FakeLoggedEpisode:
    """An episode that ran in no time."""

    def __init__(self, scenario: object) -> None:
        self.scenario = scenario

    def run(self, rerun_path: Path | None, progress: bool, view: object = None
            ) -> dict[str, Any]:
        return {"result": {"released_fraction": 0.0, "bindings": 0, "released_by_rule": {},
                           "gap_m": {"median": 0.0}, "knife_tracking_error_m": {"median": 0.0}},
                "timing": {"real_time_factor": 1.0}}


def _run(monkeypatch: pytest.MonkeyPatch, writer: Callable[..., Any]) -> list[str]:
    monkeypatch.setattr("cell.sim.command.load", lambda args: None)
    monkeypatch.setattr("cell.sim.episodelog.LoggedEpisode", FakeLoggedEpisode)
    monkeypatch.setattr("cell.sim.profiled.start_episode",
                        lambda scenario, kind: kind(scenario))
    monkeypatch.setattr("cell.sim.episodelog.write_log", writer)
    return ["run", str(PROJECT_ROOT / "scenarios" / "quick.toml"), "--log", "out", "--quiet"]


#: Each command: how to run it with a writer, the writer's call that the tests stop, and a
#: file its output holds.
COMMANDS = {"diagnose --report": (_diagnose, 0, "report.md"),
            "diagnose-logs --out": (_diagnose_logs, 0, "diagnosis.json"),
            "replay --out": (_replay, 1, "replay.json"), "run --log": (_run, 0, "log.toml")}


@pytest.fixture
def work(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.mark.parametrize("command", COMMANDS)
@pytest.mark.parametrize("existing", [False, True], ids=["new", "existing"])
@pytest.mark.parametrize("raised", [KeyboardInterrupt(), Stopped(signal.SIGTERM),
                                    OSError("disk full")], ids=["ctrl-c", "sigterm", "failed"])
def test_a_writer_stopped_or_failing_midway_leaves_the_folder_as_it_was(
        work: Path, monkeypatch: pytest.MonkeyPatch, command: str, existing: bool,
        raised: BaseException) -> None:
    setup, after, mark = COMMANDS[command]
    kept = old_output(work, mark) if existing else {}
    argv = setup(monkeypatch, half_writer(raised, after))
    if isinstance(raised, KeyboardInterrupt):  # Stopped (SIGTERM) too
        assert main(argv) == (143 if isinstance(raised, Stopped) else 130)
    else:
        with pytest.raises(OSError, match="disk full"):
            main(argv)
    # Nothing of the command's (no d.json either: its outputs appear together), no temporary.
    assert listing(work) == kept


@pytest.mark.parametrize("command", COMMANDS)
def test_a_finished_folder_replaces_the_one_there_whole(
        work: Path, monkeypatch: pytest.MonkeyPatch, command: str) -> None:
    setup, _, mark = COMMANDS[command]
    old_output(work, mark)
    assert main(setup(monkeypatch, half_writer(None))) == 0
    assert listing(work / "out") == ({"log-a": "dir", "log-a/first.txt": WRITTEN, "log-b": "dir",
                                      "log-b/first.txt": WRITTEN} if command == "replay --out"
                                     else {"first.txt": WRITTEN})
    assert not [path for path in work.iterdir() if path.name.startswith(".")]


@pytest.mark.parametrize(("argv", "named"), [
    (["diagnose", str(EXAMPLE_SET), "--out", "d.json", "--report", "."],
     "the working folder"),
    (["diagnose", str(EXAMPLE_SET), "--out", "out/d.json", "--report", "out"],
     "the output of --out"),
    (["diagnose", "sets/one", "--out", "d.json", "--report", "sets"], "the input"),
    (["run", "logs/s.toml", "--log", "logs", "--quiet"], "the input"),
    (["run", "s.toml", "--log", "out", "--out", "out/s.json", "--quiet"],
     "the output of --out"),
    (["replay", "logs/a", "--out", "logs"], "the input"),
    (["diagnose-logs", "a", "b", "--out", "..", "--no-plots"], "the working folder"),
])
def test_a_folder_written_whole_may_not_hold_what_it_would_replace(
        work: Path, capsys: pytest.CaptureFixture[str], argv: list[str], named: str) -> None:
    (work / "logs").mkdir()
    before = listing(work)
    assert main(argv) == 2
    message = capsys.readouterr().err
    assert named in message and "replaces it whole" in message, message
    assert listing(work) == before


@pytest.mark.parametrize("command", COMMANDS)
def test_a_folder_that_is_not_the_commands_own_is_refused_not_replaced(
        work: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        command: str) -> None:
    before = old_output(work, "measurements.csv")
    setup, _, mark = COMMANDS[command]
    assert main(setup(monkeypatch, half_writer(None))) == 2
    message = capsys.readouterr().err
    assert "no earlier output of this command" in message and mark in message, message
    assert listing(work) == before


#: ``diagnose-logs`` whose writer writes one file and waits to be stopped.
STOPPED_WRITER = """
import sys, time
import cell.logs.batch, cell.logs.diagnosis, cell.logs.report
from cell.cli import main

def wait_to_be_stopped(folder, *args, **kwargs):
    (folder / "first.txt").write_text("written before the stop\\n")
    time.sleep(60)

cell.logs.batch.read_log_batch = lambda logs: None
cell.logs.diagnosis.diagnose_logs = lambda *args: None
cell.logs.report.write_log_diagnosis = wait_to_be_stopped
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("number", [signal.SIGTERM, signal.SIGINT], ids=["sigterm", "sigint"])
def test_a_stop_signal_midway_leaves_the_folder_there_as_it_was(work: Path,
                                                                number: int) -> None:
    kept = old_output(work, "diagnosis.json")
    process = subprocess.Popen(
        [sys.executable, "-c", CTRL_C_RAISES + STOPPED_WRITER, "diagnose-logs", "a", "b",
         "--out", "out", "--no-plots"], cwd=work, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONPATH": str(PROJECT_ROOT)})
    deadline = time.monotonic() + 60.0
    while not list(work.glob(".out.*.tmp/first.txt")):
        assert process.poll() is None, process.communicate()[1]
        assert time.monotonic() < deadline, "the writer never started"
        time.sleep(0.02)
    process.send_signal(number)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 128 + number, err
    assert "Traceback" not in err
    assert listing(work) == kept


def test_a_stop_between_the_two_renames_puts_the_old_folder_back(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    kept = old_output(tmp_path)
    renames = []
    rename = os.replace

    def stopped_second(source: Path, target: Path) -> None:
        renames.append(target)
        if len(renames) == 2:  # the old folder moved aside, the new one not yet in
            raise KeyboardInterrupt
        rename(source, target)

    monkeypatch.setattr(os, "replace", stopped_second)
    with pytest.raises(KeyboardInterrupt), AtomicFolder(tmp_path / "out") as target:
        (target.temporary / "new.txt").write_text("new\n")
        target.commit()
    monkeypatch.undo()
    assert listing(tmp_path) == kept


def test_a_folder_made_for_the_output_goes_with_it(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="bad"):
        write_folder(tmp_path / "new" / "deeper" / "out", lambda folder: int("bad"))
    assert listing(tmp_path) == {}


def test_a_link_to_a_folder_points_at_the_new_folder(tmp_path: Path) -> None:
    (tmp_path / "real").mkdir()
    (tmp_path / "real" / "old.txt").write_text("old\n")
    (tmp_path / "link").symlink_to("real")
    write_folder(tmp_path / "link", lambda folder: (folder / "new.txt").write_text("new\n"))
    assert (tmp_path / "link").is_symlink()
    assert listing(tmp_path / "real") == {"new.txt": "new\n"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "real"]


def test_outputs_written_together_appear_only_once_all_are_filled(tmp_path: Path) -> None:
    filled = []

    def report(folder: Path) -> None:
        (folder / "report.md").write_text("the report\n")
        filled.append(folder)

    broken: Any = None  # a content that cannot be written, after the report is filled
    with pytest.raises(TypeError):
        write_files_and_folders({tmp_path / "m.toml": "material\n",
                                 tmp_path / "d.json": broken}, {tmp_path / "report": report})
    assert filled and listing(tmp_path) == {}
    write_files_and_folders({tmp_path / "d.json": "{}"}, {tmp_path / "report": report})
    assert listing(tmp_path) == {"d.json": "{}", "report": "dir",
                                 "report/report.md": "the report\n"}
