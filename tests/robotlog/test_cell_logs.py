"""A whole cell's robot log comes in as a separation log: a log the cell wrote, re-written as a
robot records it (a ROS 2 bag, a bare MCAP file: each sensor's wrench and pose, the grasp) and
imported back, equals the original channel by channel, replays as it does and is diagnosed as
it is."""

from __future__ import annotations

import json
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cell.cli import main
from cell.measure.logs import CHANNELS, read_log
from cell.sim.episodelog import LoggedEpisode, write_log
from cell.sim.scenario import load_scenario
from tests.paths import PROJECT_ROOT
from tests.robotlogs import CELL_MAPPING_TOML, CellRobotLog, write_mcap, write_ros2_bag

pytest.importorskip("rosbags")
QUICK = PROJECT_ROOT / "scenarios" / "quick.toml"


@pytest.fixture(scope="module")
def cell_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short log of the quick scenario, its scenario beside it."""
    folder = tmp_path_factory.mktemp("cell")
    scenario = load_scenario(QUICK)
    scenario = replace(scenario, end_s=0.3, perception=replace(scenario.perception,
                                                               enabled=False))
    episode = LoggedEpisode(scenario)
    episode.run()
    shutil.copy(QUICK, folder / "scenario.toml")
    return write_log(folder / "log", episode, folder / "scenario.toml")


def _robot_logs(log_folder: Path, tmp_path: Path) -> list[Path]:
    log = CellRobotLog(read_log(log_folder).channels)
    return [write_ros2_bag(log, tmp_path / "run-bag", storage="sqlite3"),
            write_mcap(log, tmp_path / "run-mcap.mcap")]


@pytest.mark.parametrize("form", [0, 1], ids=["ros2-bag", "mcap"])
def test_an_imported_cell_log_equals_the_one_the_cell_wrote(cell_log: Path, tmp_path: Path,
                                                            form: int) -> None:
    source = _robot_logs(cell_log, tmp_path)[form]
    mapping = cell_log.parent / "cell.toml"
    mapping.write_text(CELL_MAPPING_TOML)
    assert main(["import", str(mapping), str(source), "--out", str(tmp_path / "in")]) == 0
    original, imported = read_log(cell_log), read_log(tmp_path / "in")
    assert imported.scenario.resolve() == original.scenario.resolve()
    for name in CHANNELS:
        before, after = original.channels[name], imported.channels[name]
        assert np.allclose(after.time_s, before.time_s, rtol=0.0, atol=1e-9)
        for field in ("force_n", "torque_nm", "position_m", "quaternion", "grasp"):
            mine, theirs = getattr(before, field), getattr(after, field)
            assert (mine is None) == (theirs is None), (name, field)
            if mine is not None:
                assert np.array_equal(mine, theirs), (name, field)


def test_a_mapping_without_a_sensor_names_the_channel(cell_log: Path, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture) -> None:
    source = _robot_logs(cell_log, tmp_path)[1]
    mapping = tmp_path / "cell.toml"
    mapping.write_text(CELL_MAPPING_TOML.replace('[channels.fixture]\nwrench = '
                                                 '"/fixture/wrench"\ntorque = false\n', ""))
    assert main(["import", str(mapping), str(source), "--out", str(tmp_path / "in")]) == 2
    assert "channels.fixture" in capsys.readouterr().err
    assert not (tmp_path / "in").exists()


def _with_the_logs_tables(log_folder: Path) -> str:
    """The mapping with the ``[sensors]``, ``[phases]`` and ``[outcome]`` tables of the
    cell's ``log.toml``: what a robot's bag does not record, the mapping gives."""
    text = (log_folder / "log.toml").read_text()
    return CELL_MAPPING_TOML + "\n" + text[text.index("[sensors]"):]


@pytest.mark.slow
def test_an_imported_cell_log_replays_as_the_original(cell_log: Path, tmp_path: Path) -> None:
    source = _robot_logs(cell_log, tmp_path)[1]
    mapping = cell_log.parent / "cell.toml"
    mapping.write_text(_with_the_logs_tables(cell_log))
    assert main(["import", str(mapping), str(source), "--out", str(tmp_path / "in")]) == 0
    for folder, out in ((cell_log, "a"), (tmp_path / "in", "b")):
        assert main(["replay", str(folder), "--out", str(tmp_path / out), "-q"]) == 0
    first, second = (json.loads((tmp_path / out / "replay.json").read_text()) for out in "ab")
    assert first.pop("log") == "quick-0" and second.pop("log") == "run-mcap"
    # Equal but for the times' last bits: a bag holds them in integer ns.
    assert _numbers(first) == pytest.approx(_numbers(second), rel=1e-9, abs=1e-12, nan_ok=True)
    assert _shape(first) == _shape(second)


def _shape(value: object) -> object:
    """A JSON value with each number as 0: its keys, lengths and strings."""
    if isinstance(value, dict):
        return {key: _shape(item) for key, item in value.items()}
    if isinstance(value, list):
        return [_shape(item) for item in value]
    return 0 if isinstance(value, int | float) and not isinstance(value, bool) else value


def _numbers(value: object) -> list[float]:
    """Every number in a JSON value, in order (None as NaN)."""
    if isinstance(value, dict):
        return [n for key in sorted(value) for n in _numbers(value[key])]
    if isinstance(value, list):
        return [n for item in value for n in _numbers(item)]
    if value is None:
        return [float("nan")]
    return [float(value)] if isinstance(value, int | float) else []


@pytest.mark.slow  # two log diagnoses
def test_imported_cell_logs_are_diagnosed_as_the_originals(tmp_path: Path) -> None:
    originals, imported = [], []
    for seed in (0, 1):
        scenario = load_scenario(QUICK)
        scenario = replace(scenario, seed=seed, end_s=0.3,
                           perception=replace(scenario.perception, enabled=False))
        episode = LoggedEpisode(scenario)
        episode.run()
        folder = tmp_path / f"cell-{seed}"
        folder.mkdir()
        shutil.copy(QUICK, folder / "scenario.toml")
        log = write_log(folder / "log", episode, folder / "scenario.toml")
        mapping = folder / "cell.toml"
        mapping.write_text(_with_the_logs_tables(log).replace("seed = 0", f"seed = {seed}"))
        source = write_mcap(CellRobotLog(read_log(log).channels), folder / "run.mcap")
        assert main(["import", str(mapping), str(source), "--out", str(folder / "in")]) == 0
        originals.append(str(log))
        imported.append(str(folder / "in"))
    common = ["--no-plots", "--causes", "tissue_stiffness", "--workers", "1", "-q"]
    for logs, out in ((originals, "a"), (imported, "b")):
        assert main(["diagnose-logs", *logs, "--out", str(tmp_path / out), *common]) == 0
    first, second = (json.loads((tmp_path / out / "diagnosis.json").read_text())
                     for out in "ab")
    rounds = first["timing"]["replays_by_round"]  # where the replays went, every one
    assert next(iter(rounds)) == "screening" and sum(rounds.values()) == first["timing"]["replays"]
    for result in (first, second):
        del result["logs"], result["timing"]
    assert _numbers(first) == pytest.approx(_numbers(second), rel=1e-9, abs=1e-12, nan_ok=True)
    assert _shape(first) == _shape(second)
