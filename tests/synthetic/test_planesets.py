"""Synthetic shear and mixed sets that hide orthotropy, and with it turned fibres: what they
hold, and that the diagnosis names them with the ratio and the turn (and nothing on an unchanged
set)."""

from pathlib import Path

import numpy as np
import pytest

from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.sets import diagnose_set
from cell.diagnosis.specimen.causes import CandidateMaterial
from cell.diagnosis.specimen.fitting import Problem, fit
from cell.diagnosis.specimen.planeseries import fitted_series
from cell.diagnosis.specimen.solve import fibre_turn_deg
from cell.errors import MeasurementError
from cell.measure.specimens import load_measurement_set
from cell.synthetic.planesets import write_plane_set
from cell.tissue.materialfile import load_material, material_to_toml


def test_a_hidden_orthotropy_parts_the_sheet_and_normal_shear_modes(tmp_path: Path) -> None:
    truth = write_plane_set(tmp_path / "hidden", 11, "mixed", hidden=True)
    assert truth.effect == "orthotropy"
    data = load_measurement_set(tmp_path / "hidden")
    assert [t.shear_plane for t in data.shear_tests] == ["fs", "fn", "sf", "sn"]
    assert len(data.biaxial_tests) == 3 and len(data.tests) == 2
    peak = {t.shear_plane: float(t.force_n[-1]) for t in data.shear_tests}
    # Towards the stiffer of sheets and normal the shear force is larger.
    assert (peak["fs"] > peak["fn"]) == (truth.sheet_over_normal > 1.0)
    assert "sheet" not in (tmp_path / "hidden" / "specimen.toml").read_text()
    plain = write_plane_set(tmp_path / "plain", 11, "shear", hidden=False)
    assert plain.effect is None and plain.sheet_over_normal == 1.0
    data = load_measurement_set(tmp_path / "plain")
    fs, fn = (float(t.force_n[-1]) for t in data.shear_tests[:2])
    assert fs == pytest.approx(fn, rel=0.05)  # alike but for the noise


@pytest.mark.slow  # two whole diagnoses
@pytest.mark.parametrize("kind", ["shear", "mixed"])
def test_the_diagnosis_names_a_hidden_orthotropy_with_its_ratio(tmp_path: Path,
                                                                 kind: str) -> None:
    truth = write_plane_set(tmp_path / "hidden", 1001, kind, hidden=True)
    result = diagnose_set(load_measurement_set(tmp_path / "hidden"),
                          DiagnosisParams(workers=1)).uniaxial
    assert result.causes == ("orthotropy",)
    fitted = result.extended.params["sheet_over_normal"]
    assert np.log(fitted) == pytest.approx(np.log(truth.sheet_over_normal), abs=np.log(1.15))
    write_plane_set(tmp_path / "plain", 1001, kind, hidden=False)
    assert diagnose_set(load_measurement_set(tmp_path / "plain"),
                        DiagnosisParams(workers=1)).uniaxial.causes == ()


def test_a_turned_set_hides_a_fibre_turn_that_a_fit_finds_and_the_material_file_keeps(
        tmp_path: Path) -> None:
    truth = write_plane_set(tmp_path / "turned", 51, "shear", hidden=True, turned=True)
    assert truth.causes == ("orthotropy", "fibre_direction")
    assert 8.0 <= abs(truth.fibre_turn_deg) <= 30.0
    data = load_measurement_set(tmp_path / "turned")
    model = CandidateMaterial(("orthotropy", "fibre_direction"))
    fitted = fit(Problem.of(data.specimen, fitted_series(data), 16), model, model.initial, 100)
    assert fibre_turn_deg(fitted.material) == pytest.approx(truth.fibre_turn_deg, abs=3.0)
    (tmp_path / "material.toml").write_text(material_to_toml(fitted.material))
    loaded = load_material(tmp_path / "material.toml")
    assert fibre_turn_deg(loaded) == pytest.approx(fibre_turn_deg(fitted.material), abs=1e-6)
    assert loaded.sheet_direction == pytest.approx(fitted.material.sheet_direction, abs=1e-6)
    with pytest.raises(MeasurementError, match="turned"):
        write_plane_set(tmp_path / "bad", 51, "shear", hidden=False, turned=True)


@pytest.mark.slow  # two whole diagnoses
@pytest.mark.parametrize("kind", ["shear", "mixed"])
def test_the_diagnosis_names_a_fibre_turn_with_its_angle(tmp_path: Path, kind: str) -> None:
    truth = write_plane_set(tmp_path, 1002, kind, hidden=True, turned=True)
    result = diagnose_set(load_measurement_set(tmp_path), DiagnosisParams(workers=1)).uniaxial
    assert result.causes == ("orthotropy", "fibre_direction")
    assert result.extended.params["fibre_turn_deg"] == pytest.approx(truth.fibre_turn_deg,
                                                                     abs=10.0)
