"""Synthetic shear, biaxial and mixed sets that hide one cause of the catalogue, or turned
fibres beside an orthotropy: what they hold, that the truth stays out of the files, and that
the diagnosis names a hidden cause with its parameters and the turn with its angle (and nothing
on an unchanged set)."""

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
from cell.synthetic.planesets import HIDDEN_CAUSES, PLANE_KINDS, write_plane_set
from cell.tissue.materialfile import load_material, material_to_toml


def test_a_hidden_orthotropy_parts_the_sheet_and_normal_shear_modes(tmp_path: Path) -> None:
    truth = write_plane_set(tmp_path / "hidden", 11, "mixed", "orthotropy")
    assert truth.effect == "orthotropy"
    data = load_measurement_set(tmp_path / "hidden")
    assert [t.shear_plane for t in data.shear_tests] == ["fs", "fn", "sf", "sn"]
    assert len(data.biaxial_tests) == 2
    assert sorted({t.mode for t in data.tests}) == ["compression", "cyclic", "relaxation",
                                                    "tension"]
    peak = {t.shear_plane: float(t.force_n[-1]) for t in data.shear_tests}
    # Towards the stiffer of sheets and normal the shear force is larger.
    assert (peak["fs"] > peak["fn"]) == (truth.sheet_over_normal > 1.0)
    assert "sheet" not in (tmp_path / "hidden" / "specimen.toml").read_text()
    plain = write_plane_set(tmp_path / "plain", 11, "shear", None)
    assert plain.effect is None and plain.sheet_over_normal == 1.0 and plain.reported() == {
        "young_pa": plain.modulus_pa}
    data = load_measurement_set(tmp_path / "plain")
    fs, fn = (float(t.force_n[-1]) for t in data.shear_tests[:2])
    assert fs == pytest.approx(fn, rel=0.05)  # alike but for the noise


@pytest.mark.parametrize("kind", PLANE_KINDS)
def test_each_kind_writes_its_protocol_and_keeps_the_truth_out(tmp_path: Path,
                                                               kind: str) -> None:
    truth = write_plane_set(tmp_path, 7, kind, "viscoelasticity")
    data = load_measurement_set(tmp_path)
    tests = (*data.tests, *data.shear_tests, *data.biaxial_tests)
    assert {"shear": 10, "biaxial": 9, "mixed": 13}[kind] == len(tests)
    # A relaxation shows only where a test holds: every kind has a ramp and a hold.
    assert max(float(t.time_s[-1]) for t in tests) > 100.0
    assert 0.35 <= truth.magnitudes["relaxed"] <= 0.7
    assert truth.reported()["relaxation_weight_0"] > 0.0
    text = (tmp_path / "tests.csv").read_text() + (tmp_path / "specimen.toml").read_text()
    assert not [name for name in truth.magnitudes if name in text]


def test_a_hidden_offset_shifts_every_force_column(tmp_path: Path) -> None:
    truth = write_plane_set(tmp_path, 5, "biaxial", "force_offset")
    assert truth.offset_n != 0.0 and set(truth.reported()) == {"young_pa", "force_offset_n"}
    first = load_measurement_set(tmp_path).biaxial_tests[0]
    # At rest the edges read the offset (and noise of 1 % of the peak).
    peak = float(np.abs(first.force_n).max())
    assert first.force_n[0] == pytest.approx(truth.offset_n, abs=0.05 * peak)
    assert first.force_x_n[0] == pytest.approx(truth.offset_n, abs=0.05 * peak)


def test_a_kind_hides_only_what_it_can_show(tmp_path: Path) -> None:
    assert "biaxial" not in HIDDEN_CAUSES["tension_compression_asymmetry"].kinds
    with pytest.raises(MeasurementError, match="biaxial sets hide one of"):
        write_plane_set(tmp_path, 1, "biaxial", "orthotropy")
    with pytest.raises(MeasurementError, match="kind"):
        write_plane_set(tmp_path, 1, "torsion", None)
    assert not (tmp_path / "tests.csv").exists()


@pytest.mark.slow  # two whole diagnoses
@pytest.mark.parametrize("kind", ["shear", "mixed"])
def test_the_diagnosis_names_a_hidden_orthotropy_with_its_ratio(tmp_path: Path,
                                                                 kind: str) -> None:
    truth = write_plane_set(tmp_path / "hidden", 1001, kind, "orthotropy")
    result = diagnose_set(load_measurement_set(tmp_path / "hidden"),
                          DiagnosisParams(workers=1)).uniaxial
    assert result.causes == ("orthotropy",)
    fitted = result.extended.params["sheet_over_normal"]
    assert np.log(fitted) == pytest.approx(np.log(truth.sheet_over_normal), abs=np.log(1.15))
    write_plane_set(tmp_path / "plain", 1001, kind, None)
    assert diagnose_set(load_measurement_set(tmp_path / "plain"),
                        DiagnosisParams(workers=1)).uniaxial.causes == ()


def test_a_turned_set_hides_a_fibre_turn_that_a_fit_finds_and_the_material_file_keeps(
        tmp_path: Path) -> None:
    truth = write_plane_set(tmp_path / "turned", 51, "shear", ("orthotropy", "fibre_direction"))
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
    # A turn shows only beside an anisotropy of the lattice: never hidden alone.
    with pytest.raises(MeasurementError, match="got 'fibre_direction'"):
        write_plane_set(tmp_path / "bad", 51, "shear", "fibre_direction")
    with pytest.raises(MeasurementError, match="biaxial sets hide one of"):
        write_plane_set(tmp_path / "bad", 51, "biaxial", ("anisotropy", "fibre_direction"))


@pytest.mark.slow  # two whole diagnoses
@pytest.mark.parametrize("kind", ["shear", "mixed"])
def test_the_diagnosis_names_a_fibre_turn_with_its_angle(tmp_path: Path, kind: str) -> None:
    truth = write_plane_set(tmp_path, 1002, kind, ("orthotropy", "fibre_direction"))
    result = diagnose_set(load_measurement_set(tmp_path), DiagnosisParams(workers=1)).uniaxial
    assert result.causes == ("orthotropy", "fibre_direction")
    assert result.extended.params["fibre_turn_deg"] == pytest.approx(truth.fibre_turn_deg,
                                                                     abs=10.0)
