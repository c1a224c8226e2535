"""Scenario files: the default loads, and every wrong key, type, value or syntax is refused with
an error naming the file and the dotted key, before the command line writes anything."""

from __future__ import annotations

from pathlib import Path

import pytest

from cell.cli import main
from cell.errors import ScenarioError
from cell.sim.scenario import Scenario, load_scenario
from tests.paths import DEFAULT_SCENARIO
from tests.robotarms import UR5E, write_ur5e

DEFAULT = DEFAULT_SCENARIO

#: A file text and the dotted key its error must name.
BAD_SCENARIOS = [
    pytest.param(
        "[cut]\nspeed_m_s = 0.03\nsped_m_s = 0.03\n",
        "cut.sped_m_s",
        id="unknown-key-in-known-table",
    ),
    pytest.param("[cutting]\nspeed_m_s = 0.03\n", "cutting", id="unknown-table"),
    pytest.param('[arms.knife]\nflang = "tool0"\n', "arms.knife.flang", id="unknown-arm-key"),
    pytest.param('[arms.gripper]\nbuiltin = "ur10"\n', "arms.gripper.builtin",
                 id="unknown-built-in-arm"),
    pytest.param('[arms.camera]\nfile = "lwr.urdf"\n', "arms.camera.file",
                 id="missing-robot-file"),
    pytest.param("[arms.knife]\na_m = [0.0, 0.4]\nd_m = [0.3]\n", "arms.knife.theta0_rad",
                 id="dh-table-of-two-lengths"),
    pytest.param("[steering]\nmiddle_fraction = 1.5\n", "steering.middle_fraction",
                 id="steering-window-past-the-cut"),
    pytest.param("[steering]\nenabled = 1\n", "steering.enabled", id="number-for-switch"),
    pytest.param('[cut]\nspeed_m_s = "fast"\n', "cut.speed_m_s", id="string-for-number"),
    pytest.param("[tissue]\nlength_m = true\n", "tissue.length_m", id="bool-for-number"),
    pytest.param(
        "[simulation]\nsolver_iterations = 1.5\n",
        "simulation.solver_iterations",
        id="float-for-integer",
    ),
    pytest.param(
        '[aponeurosis]\nrelease_rules = "knife"\n',
        "aponeurosis.release_rules",
        id="string-for-list",
    ),
    pytest.param("[pull]\ndirection = [0.0, 1.0]\n", "pull.direction", id="short-vector"),
    pytest.param("[cut]\nspeed_m_s = -0.03\n", "cut.speed_m_s", id="negative-speed"),
    pytest.param(
        '[aponeurosis]\nrelease_rules = ["knife", "laser"]\n',
        "aponeurosis.release_rules",
        id="unknown-release-rule",
    ),
    pytest.param("[cut]\ncut_fraction = 1.5\n", "cut.cut_fraction", id="cut-fraction-above-one"),
    pytest.param("[cut]\nspeed_m_s = nan\n", "cut.speed_m_s", id="nan-speed"),
    pytest.param(
        "[tissue]\nvalley_depth_m = 0.5\n", "tissue.valley_depth_m", id="tissue-cross-field-check"
    ),
    pytest.param(
        '[material]\nmodel = "continuum"\npoisson = 0.5\n',
        "material.poisson",
        id="material-error-becomes-scenario-error",
    ),
    pytest.param(
        '[scenario]\nnmae = "typo"\n', "scenario.nmae", id="unknown-key-in-scenario-table"
    ),
    pytest.param(
        '[scenario]\nend_s = "soon"\n', "scenario.end_s", id="wrong-type-in-scenario-table"
    ),
    pytest.param(
        "[scenario]\nsettle_s = 0.0\n", "scenario.settle_s", id="bad-value-in-scenario-table"
    ),
    pytest.param("cut = 3\n", "cut", id="table-given-as-value"),
]


def _write(tmp_path: Path, text: str, name: str = "bad.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_default_scenario_loads() -> None:
    scenario = load_scenario(DEFAULT)
    assert isinstance(scenario, Scenario)
    assert scenario.name == "default"
    assert scenario.cut.speed_m_s == pytest.approx(0.03)
    assert scenario.tissue.length_m == pytest.approx(0.45)
    assert scenario.aponeurosis.release_rules == ("force", "tearing")
    assert scenario.aponeurosis.tearing_stretch_m == pytest.approx(0.01)


def test_relative_default_path_loads(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(DEFAULT.parents[1])
    assert load_scenario("scenarios/default.toml") == load_scenario(DEFAULT)


def test_empty_file_gives_the_defaults(tmp_path: Path) -> None:
    assert load_scenario(_write(tmp_path, "", "empty.toml")) == Scenario()


def test_values_are_converted_to_the_declared_types(tmp_path: Path) -> None:
    path = _write(tmp_path, "[cut]\nspeed_m_s = 1\n[pull]\ndirection = [0, 1, 0]\n", "ok.toml")
    scenario = load_scenario(path)
    assert type(scenario.cut.speed_m_s) is float
    assert scenario.pull.direction == (0.0, 1.0, 0.0)
    assert all(type(c) is float for c in scenario.pull.direction)
    # Keys left out keep their defaults, table by table.
    assert scenario.cut.depth_m == Scenario().cut.depth_m
    assert scenario.tissue == Scenario().tissue


def test_scenario_table_sets_name_seed_and_end(tmp_path: Path) -> None:
    path = _write(tmp_path, '[scenario]\nname = "short"\nseed = 7\nend_s = 2\n', "ok.toml")
    scenario = load_scenario(path)
    assert (scenario.name, scenario.seed, scenario.end_s) == ("short", 7, 2.0)


@pytest.mark.parametrize(("text", "key"), BAD_SCENARIOS)
def test_bad_scenario_error_names_file_and_dotted_key(tmp_path: Path, text: str, key: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(ScenarioError) as caught:
        load_scenario(path)
    error = caught.value
    assert error.file == str(path)
    assert error.field == key
    assert str(error).startswith(f"{path}, {key}: ")


def test_unknown_key_names_file_and_key_and_lists_known_keys(tmp_path: Path) -> None:
    path = _write(tmp_path, "[cut]\nsped_m_s = 0.03\n")
    with pytest.raises(ScenarioError, match=r"cut\.sped_m_s") as caught:
        load_scenario(path)
    assert str(path) in str(caught.value)
    assert "speed_m_s" in caught.value.message  # the key that was meant is offered


def test_unknown_release_rule_names_the_rule(tmp_path: Path) -> None:
    path = _write(tmp_path, '[aponeurosis]\nrelease_rules = ["laser"]\n')
    with pytest.raises(ScenarioError, match="laser"):
        load_scenario(path)


def test_invalid_toml_names_file_and_line(tmp_path: Path) -> None:
    path = _write(tmp_path, "[cut]\nspeed_m_s = 0.03\n[pull\ndistance_m = 0.1\n")
    with pytest.raises(ScenarioError) as caught:
        load_scenario(path)
    error = caught.value
    assert error.file == str(path)
    assert str(path) in str(error)
    assert "not valid TOML" in error.message
    assert "line 3" in error.message


def test_missing_file_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "absent.toml"
    with pytest.raises(ScenarioError, match="file not found") as caught:
        load_scenario(path)
    assert caught.value.file == str(path)


@pytest.mark.parametrize(
    "text",
    ["[cut]\nspeed_m_s = -0.03\n", "[cutting]\n", "[cut\n", '[scenario]\nnmae = "typo"\n'],
    ids=["bad-value", "unknown-table", "bad-syntax", "unknown-scenario-key"],
)
def test_cli_refuses_bad_scenario_and_writes_nothing(
    tmp_path: Path, text: str, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = _write(tmp_path, text)
    out = tmp_path / "out" / "summary.json"
    rrd = tmp_path / "out" / "episode.rrd"
    code = main(["run", str(bad), "--out", str(out), "--rerun", str(rrd), "--quiet"])
    assert code == 2
    assert not out.exists()
    assert not rrd.exists()
    assert not (tmp_path / "out").exists()
    err = capsys.readouterr().err
    assert str(bad) in err


def test_cli_leaves_existing_summary_byte_identical(tmp_path: Path) -> None:
    bad = _write(tmp_path, "[cut]\ncut_fraction = 1.5\n")
    out = tmp_path / "summary.json"
    rrd = tmp_path / "episode.rrd"
    previous = b'{"result": {"released_fraction": 1.0}}\n'
    out.write_bytes(previous)
    code = main(["run", str(bad), "--out", str(out), "--rerun", str(rrd), "--quiet"])
    assert code == 2
    assert out.read_bytes() == previous
    assert not rrd.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml", "summary.json"]


def test_arms_named_by_file_are_found_beside_the_scenario(tmp_path: Path) -> None:
    write_ur5e(tmp_path, "urdf")
    path = _write(tmp_path, '[arms.knife]\nfile = "ur5e.urdf"\n')
    arms = load_scenario(path).arms
    assert arms.knife.file == str(tmp_path / "ur5e.urdf")
    assert arms.gripper == Scenario().arms.gripper
    assert arms.cell_arms()["knife_arm"].max_speed_rad_s == UR5E.max_speed_rad_s


def test_a_robot_file_without_the_flange_names_the_scenario_and_key(tmp_path: Path) -> None:
    write_ur5e(tmp_path, "xml")
    path = _write(tmp_path, '[arms.knife]\nfile = "ur5e.xml"\nflange = "tool0"\n'
                  f"max_speed_rad_s = {list(UR5E.max_speed_rad_s)}\n")
    with pytest.raises(ScenarioError, match="tool0") as caught:
        load_scenario(path)
    assert (caught.value.file, caught.value.field) == (str(path), "arms.knife.flange")
