"""``musclecell scenarios``: the shipped examples listed and copied out, the copies usable from
any folder."""

from __future__ import annotations

from pathlib import Path

import pytest

from cell.cli import main
from cell.sim.examples import SCENARIOS, copy_example, examples
from cell.sim.scenario import load_scenario
from tests.paths import DEFAULT_SCENARIO, EXAMPLE_SET, PROJECT_ROOT


def test_the_list_names_every_scenario_sweep_script_and_measured_set(
        capsys: pytest.CaptureFixture) -> None:
    assert main(["scenarios"]) == 0
    # Each line: the kind (13 columns), the name, its summary.
    listed = {(line[:13].strip(), line[14:].split()[0])
              for line in capsys.readouterr().out.splitlines()}
    assert {("scenario", "default"), ("scenario", "quick"), ("sweep", "sweeps/binding_strength"),
            ("script", "learn_cut"), ("measured set", EXAMPLE_SET.name)} <= listed
    assert len(listed) == len(examples())
    assert SCENARIOS.samefile(PROJECT_ROOT / "scenarios")


def test_a_copied_scenario_runs_from_another_folder_as_the_shipped_one(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["scenarios", "copy", "default"]) == 0
    # Its material is the package's (assets/...), found wherever the copy lies.
    assert load_scenario(tmp_path / "default.toml") == load_scenario(DEFAULT_SCENARIO)


def test_a_measured_set_is_copied_as_its_folder(tmp_path: Path) -> None:
    copied = copy_example(EXAMPLE_SET.name, tmp_path / "mine")
    assert sorted(path.name for path in copied.iterdir()) == sorted(
        path.name for path in EXAMPLE_SET.iterdir())
    assert (copied / "tests.csv").read_bytes() == (EXAMPLE_SET / "tests.csv").read_bytes()


def test_a_copy_never_overwrites(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    mine = tmp_path / "quick.toml"
    mine.write_text("# mine\n")
    assert main(["scenarios", "copy", "quick.toml", str(tmp_path)]) == 2
    assert "quick.toml, DEST: exists" in capsys.readouterr().err
    assert mine.read_text() == "# mine\n"


def test_an_unknown_example_is_named_with_the_known_ones(capsys: pytest.CaptureFixture) -> None:
    assert main(["scenarios", "copy", "nope"]) == 2
    assert "no shipped example 'nope'; known: default," in capsys.readouterr().err
