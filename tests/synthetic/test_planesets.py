"""Synthetic shear and mixed sets that hide orthotropy: what they hold, and that the diagnosis
names it with its ratio (and nothing on an unchanged set)."""

from pathlib import Path

import numpy as np
import pytest

from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.sets import diagnose_set
from cell.measure.specimens import load_measurement_set
from cell.synthetic.planesets import write_plane_set


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
