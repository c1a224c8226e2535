"""Separation logs: written by the cell's episodes, read back, refused when bad (named errors,
exit 2, nothing written), and replayed."""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cell.errors import (
    LogScenarioError,
    MissingChannelError,
    QuaternionError,
    SampleError,
    TimeOrderError,
)
from cell.logs.replay import replay
from cell.measure.logs import read_log
from cell.sim.episodelog import LoggedEpisode, write_log
from cell.sim.scenario import load_scenario
from tests.paths import PROJECT_ROOT
from tests.refusals import refused

QUICK = PROJECT_ROOT / "scenarios" / "quick.toml"


@pytest.fixture(scope="module")
def short_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    scenario = load_scenario(QUICK)
    scenario = replace(scenario, end_s=0.2, perception=replace(scenario.perception,
                                                               enabled=False))
    episode = LoggedEpisode(scenario)
    episode.run()
    folder = tmp_path_factory.mktemp("logs") / "short"
    write_log(folder, episode, QUICK)
    # Beside the log, the scenario it names by its path from there.
    shutil.copy(QUICK, folder / "scenario.toml")
    text = (folder / "log.toml").read_text()
    (folder / "log.toml").write_text(
        "\n".join('scenario = "scenario.toml"' if line.startswith("scenario =") else line
                  for line in text.splitlines()) + "\n")
    return folder


def test_a_written_log_reads_back(short_log: Path) -> None:
    log = read_log(short_log)
    knife, fixture = log.channels["knife"], log.channels["fixture"]
    assert len(knife.time_s) == 10 and np.all(np.diff(knife.time_s) > 0)
    assert np.allclose(np.linalg.norm(knife.quaternion, axis=1), 1.0)
    assert log.channels["gripper"].grasp is not None and fixture.position_m is None
    assert log.outcome["bindings"] > 0 and log.seed == 0


def _broken(short_log: Path, tmp_path: Path, channel: str, edit: callable) -> Path:
    folder = tmp_path / "bad"
    shutil.copytree(short_log, folder)
    path = folder / channel
    lines = path.read_text().splitlines()
    path.write_text("\n".join(edit(lines)) + "\n")
    return folder


def _cell(lines: list[str], row: int, column: str, value: str) -> list[str]:
    header = lines[0].split(",")
    cells = lines[row].split(",")
    cells[header.index(column)] = value
    return [*lines[:row], ",".join(cells), *lines[row + 1:]]


@pytest.mark.parametrize(("channel", "edit", "error", "words"), [
    ("knife.csv", lambda lines: [",".join(c for c in line.split(",")[:-4])
                                 for line in lines], MissingChannelError, "column force_z_N"),
    ("gripper.csv", lambda lines: _cell(lines, 3, "qw", "0.5"), QuaternionError, "line 4"),
    ("fixture.csv", lambda lines: _cell(lines, 5, "time_s", "0.0"), TimeOrderError, "line 6"),
    ("knife.csv", lambda lines: _cell(lines, 2, "force_x_N", "nan"), SampleError, "line 3"),
    ("log.toml", lambda lines: ['scenario = "gone.toml"' if line.startswith("scenario")
                                else line for line in lines], LogScenarioError, "log.scenario"),
])
def test_a_bad_log_is_a_named_error(short_log: Path, tmp_path: Path, channel: str,
                                    edit: callable, error: type, words: str) -> None:
    folder = _broken(short_log, tmp_path, channel, edit)
    with pytest.raises(error, match=words):
        read_log(folder)


@pytest.mark.slow  # a process of its own: seconds to start
def test_a_log_without_a_channel_file_is_refused_by_replay(short_log: Path,
                                                           tmp_path: Path) -> None:
    folder = tmp_path / "bad"
    shutil.copytree(short_log, folder)
    (folder / "fixture.csv").unlink()
    refused(tmp_path, "replay", "bad", "--out", "out", words=("fixture.csv", "missing"))


@pytest.mark.slow
def test_a_replay_of_a_cell_log_reproduces_its_channels(tmp_path: Path) -> None:
    scenario = load_scenario(QUICK)
    episode = LoggedEpisode(scenario)
    episode.run()
    write_log(tmp_path / "log", episode, QUICK)
    log = read_log(tmp_path / "log")
    result = replay(log)
    # Each tool sits where the logged one sat under the meat's load, not off it by the servos'
    # give as a replay aimed at the logged pose alone would.
    for stem in ("knife", "gripper"):
        logged = log.channels[stem]
        at_work = logged.time_s >= log.sensors[f"{stem}_tare_s"] + 0.2
        off_m = np.linalg.norm(logged.position_m - result.simulated[stem].position_m, axis=1)
        assert off_m[at_work].mean() < 3e-5, (stem, off_m[at_work].mean())
    summary = result.summary()
    for name in ("knife_force", "gripper_force", "fixture_force"):
        for phase, share in summary["rmse_share"][name].items():
            assert share is None or share < 0.15, (name, phase, share)
    for counts in summary["counts"].values():
        assert counts["difference_share"] <= 0.05


@pytest.mark.slow
def test_a_replay_zeroes_the_gripper_as_the_log_did(tmp_path: Path) -> None:
    # The gripper is tared in its steady approach, so a replay takes the log's zero: after the
    # short stop at the grasp point the two agree to the noise (a zero taken in the stop left
    # a constant (0, 0.5, -1.2) N between them).
    scenario = load_scenario(QUICK)
    scenario = replace(scenario, end_s=3.2, perception=replace(scenario.perception,
                                                               enabled=False))
    episode = LoggedEpisode(scenario)
    episode.run()
    write_log(tmp_path / "log", episode, QUICK)
    log = read_log(tmp_path / "log")
    logged, simulated = log.channels["gripper"], replay(log).simulated["gripper"]
    after = logged.time_s > log.sensors["gripper_tare_s"] + 0.2
    at = np.stack([np.interp(logged.time_s, simulated.time_s, simulated.force_n[:, k])
                   for k in range(3)], axis=1)
    residual = (logged.force_n - at)[after]
    assert after.sum() >= 20
    assert np.all(np.abs(residual.mean(axis=0)) < 0.1)
