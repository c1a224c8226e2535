"""A scenario written from another's tables names the same files, wherever it is written."""

from __future__ import annotations

from pathlib import Path

from cell.config import read_toml
from cell.sim.scenario import load_scenario
from cell.sim.scenariotoml import resolved_tables, tables_toml
from tests.robotarms import arms_scenario, write_seven_axis, write_ur5e


def test_a_rewritten_scenario_finds_its_robot_files(tmp_path: Path) -> None:
    source = tmp_path / "source"
    source.mkdir()
    write_ur5e(source, "urdf")
    write_seven_axis(source)
    path = arms_scenario(source, "ur5e.urdf")
    tables = resolved_tables(read_toml(path), load_scenario(path))
    copy = tmp_path / "elsewhere.toml"
    copy.write_text(tables_toml(tables, "rewritten"))
    assert load_scenario(copy).arms == load_scenario(path).arms
