"""What the log diagnosis writes for a user to run next: the extended scenario, loaded, is
the world the named causes made, whatever the material's kind; the report and the cause table
of docs/logs.md name the scenario keys each cause changes."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from cell.logs.causes import CAUSES, changed_world, scenario_keys
from cell.logs.report import SCENARIO, write_extended_world
from cell.sim.scenario import load_scenario
from tests.paths import DEFAULT_SCENARIO, PROJECT_ROOT

#: A magnitude for each kind of cause: a factor of 1.7, or 0.3 rad.
MAGNITUDE = {"factor": math.log(1.7), "angle": 0.3}


def _continuum_scenario(folder: Path) -> Path:
    """The default scenario with a continuum material given inline (with a cutting table)."""
    text = DEFAULT_SCENARIO.read_text(encoding="utf-8")
    start = text.index("[material]")
    end = text.index("\n[", start + 1)
    material = ('[material]\nmodel = "continuum"\nyoung_pa = 3.0e4\n'
                'cutting = { toughness_j_m2 = 300.0, face_friction = 0.3 }\n')
    path = folder / "continuum.toml"
    path.write_text(text[:start] + material + text[end:], encoding="utf-8")
    return path


@pytest.mark.parametrize("name", sorted(CAUSES))
@pytest.mark.parametrize("kind", ["mass_spring", "continuum"])
def test_the_extended_scenario_loaded_is_the_world_the_cause_made(
        name: str, kind: str, tmp_path: Path) -> None:
    scenario_file = DEFAULT_SCENARIO if kind == "mass_spring" else _continuum_scenario(tmp_path)
    belief = load_scenario(scenario_file)
    magnitudes = {name: MAGNITUDE[CAUSES[name].kind]}
    out = tmp_path / "out"
    out.mkdir()
    write_extended_world(out, scenario_file, belief, magnitudes, [])
    assert load_scenario(out / SCENARIO) == changed_world(belief, magnitudes)


def test_two_causes_at_once_are_both_in_the_extended_scenario(tmp_path: Path) -> None:
    belief = load_scenario(DEFAULT_SCENARIO)
    magnitudes = {"tearing_threshold": math.log(0.5), "tissue_stiffness": math.log(2.5)}
    write_extended_world(tmp_path, DEFAULT_SCENARIO, belief, magnitudes, ["sensor_offset"])
    extended = load_scenario(tmp_path / SCENARIO)
    assert extended == changed_world(belief, magnitudes)
    assert extended.aponeurosis.tearing_stretch_m == pytest.approx(
        0.5 * belief.aponeurosis.tearing_stretch_m)
    assert "Not in a scenario's keys: sensor_offset" in (tmp_path / SCENARIO).read_text()


def _documented_keys() -> dict[str, set[str]]:
    """The keys named in the scenario keys column of docs/logs.md's cause table, by cause."""
    text = (PROJECT_ROOT / "docs" / "logs.md").read_text(encoding="utf-8")
    table = text[text.index("| cause | the change (magnitude `m`) | scenario keys |"):]
    documented = {}
    for row in table.splitlines()[2:]:
        if not row.startswith("|"):
            break
        cells = row.strip("|").split("|")
        documented[cells[0].strip(" `")] = set(re.findall(r"`([a-z0-9_.]+)`", cells[2]))
    return documented


@pytest.mark.parametrize("kind", ["mass_spring", "continuum"])
def test_the_docs_name_every_scenario_key_a_cause_changes(kind: str, tmp_path: Path) -> None:
    belief = load_scenario(DEFAULT_SCENARIO if kind == "mass_spring"
                           else _continuum_scenario(tmp_path))
    documented = _documented_keys()
    for name in CAUSES:
        assert set(scenario_keys(name, belief)) <= documented[name], name
