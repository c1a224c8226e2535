"""`musclecell diagnose`: the contract's JSON field by field, the extended material in the cell,
bad input."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import pytest

from cell.cli import main
from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.specimen.causes import UNEXPLAINED, UNIAXIAL_CAUSES
from cell.diagnosis.specimen.diagnosis import diagnose
from cell.errors import DiagnosisError
from cell.measure.specimens import load_measurement_set, load_specimen
from cell.sim.episode import Episode
from cell.sim.scenario import load_scenario
from cell.synthetic.specimen import write_hidden_effect_set
from cell.tissue.material import MassSpringMaterial
from cell.tissue.materialfile import load_material
from tests.coarse import coarse
from tests.paths import DEFAULT_SCENARIO, EXAMPLE_SET


@pytest.fixture(scope="module")
def diagnosed(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, Path]:
    """A viscoelastic set diagnosed from the command line: the JSON and the material file."""
    folder = tmp_path_factory.mktemp("viscoelastic")
    write_hidden_effect_set(folder / "set", 7, "viscoelasticity")
    out = folder / "out" / "diagnosis.json"
    assert main(["diagnose", str(folder / "set"), "--out", str(out)]) == 0
    return json.loads(out.read_text()), out.with_name("diagnosis-material.toml")


def _entry(entry: dict) -> None:
    assert isinstance(entry["model"], str) and entry["model"]
    assert all(isinstance(v, float) and math.isfinite(v) for v in entry["params"].values())
    assert entry["heldout_rmse_N"] > 0.0


def test_json_follows_the_contract_field_by_field(diagnosed: tuple[dict, Path]) -> None:
    report, _ = diagnosed
    assert {"baseline", "causes", "candidates", "extended", "gain"} <= set(report)
    _entry(report["baseline"])
    _entry(report["extended"])
    assert report["baseline"]["params"].keys() == {"young_pa"}
    assert report["causes"][0] == "viscoelasticity"
    assert set(report["causes"]) <= set(UNIAXIAL_CAUSES) | {UNEXPLAINED}
    assert [c["cause"] for c in report["candidates"]] == list(UNIAXIAL_CAUSES)
    for candidate in report["candidates"]:
        assert set(candidate) >= {"cause", "params", "heldout_rmse_N", "selected"}
        assert candidate["selected"] == (candidate["cause"] in report["causes"])
        assert candidate["heldout_rmse_N"] > 0.0
    assert report["gain"] == pytest.approx(
        1.0 - report["extended"]["heldout_rmse_N"] / report["baseline"]["heldout_rmse_N"])
    assert report["gain"] > 0.5
    assert "relaxation_weight_0" in report["extended"]["params"]
    assert "relaxation_time_1_s" in report["extended"]["params"]


def test_json_gives_the_evidence_of_each_cause(diagnosed: tuple[dict, Path]) -> None:
    report, _ = diagnosed
    causes = [c for c in report["causes"] if c != UNEXPLAINED]
    assert [e["cause"] for e in report["evidence"]] == causes
    for evidence in report["evidence"]:
        assert evidence["heldout_rmse_with_N"] == report["extended"]["heldout_rmse_N"]
        assert evidence["heldout_rmse_without_N"] > evidence["heldout_rmse_with_N"]
        assert 0.5 <= evidence["improved_fraction"] <= 1.0
        assert evidence["params"]
        for entry in evidence["params"].values():
            low, high = entry["ci95"]
            assert low <= entry["value"] <= high


def test_extended_material_loads_into_the_default_scenario(diagnosed: tuple[dict, Path],
                                                           tmp_path: Path) -> None:
    _, material_path = diagnosed
    material = load_material(material_path)
    assert isinstance(material, MassSpringMaterial)
    assert sum(material.relaxation_weights) > 0.2
    default = DEFAULT_SCENARIO.read_text()
    line = next(x for x in default.splitlines() if x.startswith("file = "))
    scenario_path = tmp_path / "default_with_fitted_meat.toml"
    scenario_path.write_text(default.replace(line, f'file = "{material_path.as_posix()}"'))
    assert load_scenario(scenario_path).material == material


@pytest.mark.slow  # a whole episode
def test_episode_runs_on_the_extended_material(diagnosed: tuple[dict, Path]) -> None:
    material = replace(load_material(diagnosed[1]), fibre_direction=(1.0, 0.0, 0.0))
    result = Episode(coarse(material=material)).run()["result"]
    assert result["released_fraction"] > 0.9


def test_a_bad_set_writes_nothing(tmp_path: Path) -> None:
    folder = tmp_path / "set"
    write_hidden_effect_set(folder, 3, None)
    lines = (folder / "tests.csv").read_text().splitlines()
    lines[5] = lines[5].rsplit(",", 1)[0] + ",nan"
    (folder / "tests.csv").write_text("\n".join(lines) + "\n")
    out = tmp_path / "diagnosis.json"
    out.write_text("before")
    assert main(["diagnose", str(folder), "--out", str(out)]) == 2
    assert out.read_text() == "before"
    assert not out.with_name("diagnosis-material.toml").exists()


def test_a_set_the_model_cannot_run_names_the_test_and_writes_nothing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "set"
    write_hidden_effect_set(folder, 3, None)
    height = load_specimen(folder / "specimen.toml").size_m[2]
    # One more test squeezes the specimen flat: no spring lattice has an equilibrium there.
    crushed = "".join(f"flat,compression,0,{t:.1f},{-height * t / 10.0:.10f},{-t:.3f}\n"
                      for t in range(11))
    with (folder / "tests.csv").open("a") as csv:
        csv.write(crushed)
    out = tmp_path / "diagnosis.json"
    assert main(["diagnose", str(folder), "--out", str(out), "--workers", "1"]) == 2
    error = capsys.readouterr().err
    assert "'flat'" in error and "does not converge" in error and "baseline" in error
    assert not out.exists() and not out.with_name("diagnosis-material.toml").exists()


def test_params_are_checked() -> None:
    with pytest.raises(DiagnosisError, match="fit_samples"):
        DiagnosisParams(fit_samples=2)
    with pytest.raises(DiagnosisError, match="workers"):
        DiagnosisParams(workers=0)


@pytest.mark.slow
def test_the_example_set_is_named_every_effect_of_its_truth_and_nothing_else() -> None:
    # Its truth (specimen.toml's header): an exponential law apart in tension and compression,
    # transversely isotropic moduli with a shear term, and quasi-linear relaxation.
    result = diagnose(load_measurement_set(EXAMPLE_SET), DiagnosisParams(workers=2))
    assert set(result.causes) - {UNEXPLAINED} == {
        "strain_stiffening", "anisotropy", "viscoelasticity", "tension_compression_asymmetry"}
    for evidence in result.evidence:
        assert evidence.heldout_rmse_without_n > 3.0 * evidence.heldout_rmse_with_n
