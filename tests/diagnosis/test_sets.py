"""The material that a diagnosis of uniaxial and cut tests writes (elastic and cutting causes)
cuts the default episode: issue 33, acceptance 4."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest

from cell.cli import main
from cell.sim.episode import Episode
from cell.sim.scenario import load_scenario
from cell.tissue.materialfile import load_material
from tests.cutsets import PLAIN, cut_set, mixed_set, press, saw


@pytest.mark.slow
def test_the_default_episode_cuts_with_the_material_a_mixed_diagnosis_writes(
        tmp_path: Path) -> None:
    truth = replace(PLAIN, slicing_efficiency=1.0, face_friction=0.4)
    paths = [press(0.005), press(0.01), press(0.03), saw(0.004), saw(0.008)]
    # A stiffening, anisotropic meat (a linear one, softer than beef across the fibres at the
    # pull's strains, let the pull tear most bindings before the knife reached them).
    mixed_set(tmp_path / "set", cut_set(truth, paths=paths),
              effect=("strain_stiffening", "anisotropy"))
    out = tmp_path / "out"
    assert main(["diagnose", str(tmp_path / "set"), "--out", str(out / "d.json"),
                 "--workers", "2"]) == 0
    causes = json.loads((out / "d.json").read_text())["causes"]
    assert {"strain_stiffening", "anisotropy", "slicing", "blade_friction"} <= set(causes)
    material = load_material(out / "d-material.toml")
    assert material.cutting.slicing_efficiency > 0.5 and material.cutting.face_friction > 0.2
    # Through a scenario file: the default scenario's keys are the library's defaults, so a
    # scenario naming only the material runs the default cell with it.
    scenario_file = tmp_path / "extended.toml"
    scenario_file.write_text(f'[material]\nfile = "{(out / "d-material.toml").as_posix()}"\n')
    scenario = load_scenario(scenario_file)
    assert scenario.material == material
    result = Episode(scenario).run()["result"]
    assert result["released_fraction"] == 1.0
    assert result["flesh_damage"]["torn_fraction"] <= 0.10
