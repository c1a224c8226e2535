"""A batch of separation logs (one batch of meat): logs that share tools, sensors and
material read together; logs that do not, a log given twice or alone, are refused with a
named error naming the file and the key that differs (exit 2, nothing written). And a log's
scenario, a path from the log's folder."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cell.errors import LogBatchError, LogScenarioError
from cell.logs.batch import read_log_batch
from cell.measure.logs import Channel, channel_rows, log_toml, read_log
from tests.fuzzing import written
from tests.paths import PROJECT_ROOT
from tests.refusals import refused

QUICK = (PROJECT_ROOT / "scenarios" / "quick.toml").read_text()
#: Another material than the default one: the paper's (scenarios/paper_material.toml).
PAPER_MATERIAL = """
[material]
model = "mass_spring"
density_kg_m3 = 1060.0
fibre_direction = [1.0, 0.0, 0.0]
[material.longitudinal]
modulus_pa = 250000.0
[material.transverse]
modulus_pa = 600000.0
"""


def _csv(channel: Channel) -> str:
    columns, rows = channel_rows(channel)
    return "\n".join([",".join(columns)] + [",".join(repr(row[c]) for c in columns)
                                            for row in rows]) + "\n"


def log_folder(folder: Path, scenario_extra: str = "", knife_rate_hz: float = 50.0) -> Path:
    """A short log of still tools beside its scenario (quick.toml and ``scenario_extra``)."""
    time_s = np.linspace(0.02, 0.1, 5)
    still = np.zeros((5, 3))
    pose = {"position_m": np.tile([0.0, 0.0, 1.0], (5, 1)),
            "quaternion": np.tile([1.0, 0.0, 0.0, 0.0], (5, 1))}
    sensors = {"knife_rate_hz": knife_rate_hz, "gripper_rate_hz": 50.0,
               "fixture_rate_hz": 50.0}
    return written(folder, {
        "scenario.toml": QUICK + scenario_extra,
        "log.toml": log_toml(folder.name, "scenario.toml", 0, sensors, (), {}),
        "knife.csv": _csv(Channel(time_s, still, still, **pose)),
        "gripper.csv": _csv(Channel(time_s, still, still, **pose, grasp=np.zeros(5))),
        "fixture.csv": _csv(Channel(time_s, still))})


def test_logs_of_one_batch_read_together(tmp_path: Path) -> None:
    batch = read_log_batch([log_folder(tmp_path / "a"), log_folder(tmp_path / "b")])
    assert [log.name for log in batch.logs] == ["a", "b"]
    assert batch.scenarios[0].seed == 0 and batch.scenarios[1].name == "quick"


@pytest.mark.parametrize(("extra", "key"), [
    ("\n[knife]\nblade_length_m = 0.25\n", "knife.blade_length_m"),
    ("\n[sensors]\nforce_noise_n = 0.2\n", "sensors.force_noise_n"),
    (PAPER_MATERIAL, "material"),
], ids=["tools", "sensors", "material"])
def test_logs_with_other_tools_sensors_or_material_are_not_one_batch(
        tmp_path: Path, extra: str, key: str) -> None:
    folders = [log_folder(tmp_path / "a"), log_folder(tmp_path / "b", extra)]
    with pytest.raises(LogBatchError, match=rf"b/scenario.toml, {key}.*share their"):
        read_log_batch(folders)


def test_logs_with_other_sensor_rates_are_not_one_batch(tmp_path: Path) -> None:
    folders = [log_folder(tmp_path / "a"), log_folder(tmp_path / "b", knife_rate_hz=200.0)]
    with pytest.raises(LogBatchError, match=r"b/log.toml, sensors.knife_rate_hz"):
        read_log_batch(folders)


def test_a_batch_needs_two_different_logs(tmp_path: Path) -> None:
    folder = log_folder(tmp_path / "a")
    with pytest.raises(LogBatchError, match="at least two"):
        read_log_batch([folder])
    with pytest.raises(LogBatchError, match="given twice"):
        read_log_batch([folder, tmp_path / "." / "a"])


@pytest.mark.slow  # a process of its own: seconds to start
def test_replay_refuses_logs_that_are_not_one_batch(tmp_path: Path) -> None:
    log_folder(tmp_path / "a")
    log_folder(tmp_path / "b", "\n[knife]\nblade_length_m = 0.25\n")
    refused(tmp_path, "replay", "a", "b", "--out", "out",
            words=("b/scenario.toml", "knife.blade_length_m", "share their tools"))


def test_a_logs_scenario_is_a_path_from_the_logs_folder(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    folder = log_folder(tmp_path / "runs" / "a")
    (folder / "scenario.toml").rename(tmp_path / "runs" / "shared.toml")
    text = (folder / "log.toml").read_text()
    (folder / "log.toml").write_text(text.replace('"scenario.toml"', '"../shared.toml"'))
    monkeypatch.chdir(tmp_path)
    assert read_log("runs/a").scenario.resolve() == tmp_path / "runs" / "shared.toml"
    (tmp_path / "runs" / "shared.toml").unlink()
    with pytest.raises(LogScenarioError, match=r"runs/a/log.toml, log.scenario: no scenario "
                                               r"file at '../shared.toml'"):
        read_log("runs/a")
