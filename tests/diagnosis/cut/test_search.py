"""The diagnosis of cut tests (cell.diagnosis.cut.causes, cutfitting, cutsearch, cutdiagnosis) on
sets that the reduced model makes, each with one hidden effect."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cell.diagnosis.cut.causes import CUT_CAUSES, CutCandidate, linear_columns
from cell.diagnosis.cut.fitting import CutProblem, best_layer_depth, fit_cut, solve_linear
from cell.diagnosis.cut.search import diagnose_cuts
from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.sets import diagnose_set
from cell.errors import DiagnosisError
from cell.measure.cuts import CutTest
from cell.measure.specimens import MeasurementSet, load_measurement_set
from cell.tissue.materialfile import load_material, material_to_toml
from tests.cutsets import BLADE, BLOCK, PLAIN, cut_set, mixed_set, press, saw
from tests.marks import slow_but

PARAMS = DiagnosisParams(workers=1)


HIDDEN = {
    "blade_friction": (replace(PLAIN, face_friction=0.4), (0.0, 0.0, 0.0)),
    "slicing": (replace(PLAIN, slicing_efficiency=1.0), (0.0, 0.0, 0.0)),
    "rate_dependent_cutting": (replace(PLAIN, rate_exponent=0.3), (0.0, 0.0, 0.0)),
    "indentation_stiffness": (replace(PLAIN, indentation_depth_m=0.004), (0.0, 0.0, 0.0)),
    "layered_toughness": (replace(PLAIN, layer_depths_m=(0.012,), layer_factors=(1.0, 1.8)),
                          (0.0, 0.0, 0.0)),
    "blade_force_offset": (PLAIN, (0.5, -0.3, 2.0)),
    "edge_loading": (replace(PLAIN, loading_depth_m=0.004), (0.0, 0.0, 0.0)),
    "edge_friction": (replace(PLAIN, edge_friction=0.5, edge_slip_m=0.002), (0.0, 0.0, 0.0)),
    "wedge_friction": (replace(PLAIN, face_modulus_pa=6e4), (0.0, 0.0, 0.0)),
}


def test_the_catalogue_has_the_specs_causes() -> None:
    assert set(CUT_CAUSES) == set(HIDDEN)
    with pytest.raises(DiagnosisError):
        CutCandidate(("tissue_stiffness",))


def test_the_baseline_fit_finds_the_toughness() -> None:
    problem = CutProblem.of(BLOCK, BLADE, cut_set(PLAIN), 64)
    model = CutCandidate((), problem.reference_speed_m_s(), BLOCK.top_z_m)
    fit = fit_cut(problem, model, model.initial, 100)
    assert fit.params["toughness_j_m2"] == pytest.approx(900.0, rel=0.01)
    assert fit.heldout_rmse_n == pytest.approx(0.2, rel=0.15)


def _misfit_rss(problem: CutProblem, model: CutCandidate, shape: np.ndarray) -> float:
    """The least-squares misfit over every sample, the linear parameters solved unbounded."""
    columns = np.vstack([linear_columns(model, shape, k) for k in problem.kinematics])
    measured = np.concatenate([t.force_n for t in problem.tests])
    misfit = columns @ np.linalg.lstsq(columns, measured, rcond=None)[0] - measured
    return float(misfit @ misfit)


def test_a_layers_depth_is_put_where_the_misfit_is_least() -> None:
    truth, _ = HIDDEN["layered_toughness"]
    problem = CutProblem.of(BLOCK, BLADE, cut_set(truth, (0.5, -0.3, 2.0), seed=2), 64)
    model = CutCandidate(("layered_toughness", "blade_force_offset"),
                         problem.reference_speed_m_s(), BLOCK.top_z_m)
    found = best_layer_depth(problem, model, model.initial)
    assert found[0] == pytest.approx(0.012, abs=3e-4)
    for depth in (0.0118, 0.012, 0.0122, 0.005, 0.02):
        assert _misfit_rss(problem, model, found) <= _misfit_rss(problem, model,
                                                                 np.array([depth])) + 1e-9


def test_a_toughness_that_no_sample_depends_on_is_zero_not_round_off() -> None:
    # Leaving out the one test that cut into the deeper layer leaves its column all zero.
    model = CutCandidate(("layered_toughness",), 0.01, BLOCK.top_z_m)
    shallow = np.linspace(0.0, 0.02, 50)
    columns = np.column_stack([shallow, np.zeros_like(shallow)])
    linear = solve_linear(columns, 800.0 * shallow, model)
    assert linear[0] == pytest.approx(800.0) and linear[1] == 0.0


def test_a_set_with_no_hidden_effect_names_none() -> None:
    assert diagnose_cuts(BLOCK, BLADE, cut_set(PLAIN, seed=3), PARAMS).causes == ()


#: The causes whose diagnosis takes longest (each seconds): run with ``-m slow``.
SLOW_CAUSES = {"edge_loading", "layered_toughness"}


@pytest.mark.parametrize("cause", slow_but(HIDDEN.keys() - SLOW_CAUSES, sorted(HIDDEN)))
def test_a_hidden_cause_is_named_with_its_parameters(cause: str) -> None:
    truth, offset = HIDDEN[cause]
    result = diagnose_cuts(BLOCK, BLADE, cut_set(truth, offset), PARAMS)
    assert result.causes == (cause,)
    assert result.gain > 0.3
    fitted = result.extended.cutting
    if cause == "blade_friction":
        assert fitted.face_friction == pytest.approx(0.4, rel=0.15)
    elif cause == "slicing":
        assert fitted.slicing_efficiency == pytest.approx(1.0, rel=0.15)
    elif cause == "rate_dependent_cutting":
        assert fitted.rate_exponent == pytest.approx(0.3, rel=0.15)
    elif cause == "indentation_stiffness":
        assert fitted.indentation_depth_m == pytest.approx(0.004, rel=0.15)
    elif cause == "layered_toughness":
        assert fitted.layer_depths_m[0] == pytest.approx(0.012, rel=0.15)
        assert fitted.layer_factors[1] == pytest.approx(1.8, rel=0.15)
    elif cause == "edge_loading":
        assert fitted.loading_depth_m == pytest.approx(0.004, rel=0.15)
    elif cause == "edge_friction":
        assert fitted.edge_friction == pytest.approx(0.5, rel=0.15)
        assert fitted.edge_slip_m == pytest.approx(0.002, rel=0.15)
    elif cause == "wedge_friction":
        assert fitted.face_modulus_pa == pytest.approx(6e4, rel=0.15)
    else:
        np.testing.assert_allclose(result.extended.offset_n, offset, atol=0.1)


@pytest.mark.parametrize("slicing", [0.0, 1.0])
def test_a_sawing_and_a_press_cut_together_tell_whether_slicing_acts(slicing: float) -> None:
    truth = replace(PLAIN, slicing_efficiency=slicing)
    tests = cut_set(truth, paths=[press(0.01), saw(0.006)], seed=5)
    causes = diagnose_cuts(BLOCK, BLADE, tests, PARAMS).causes
    assert ("slicing" in causes) == (slicing > 0)


def _write_cut_set(folder: Path, tests: tuple[CutTest, ...]) -> None:
    """A measurement set of cut tests alone, as the spec writes it."""
    folder.mkdir()
    (folder / "specimen.toml").write_text(
        "[block]\nsize_m = [0.06, 0.04, 0.03]\n\n[blade]\nedge_length_m = 0.12\n"
        "thickness_m = 0.0015\nedge_direction = [0.0, 1.0, 0.0]\n"
        "blade_normal = [1.0, 0.0, 0.0]\n")
    rows = ["test_id,mode,time_s,edge_x_m,edge_y_m,edge_z_m,force_x_N,force_y_N,force_z_N"]
    for test in tests:
        for t, edge, force in zip(test.time_s, test.edge_m, test.force_n, strict=True):
            rows.append(",".join([test.test_id, "cut", repr(float(t)),
                                  *(repr(float(v)) for v in (*edge, *force))]))
    (folder / "tests.csv").write_text("\n".join(rows) + "\n")


def test_a_set_of_cut_tests_is_diagnosed_and_its_material_written(tmp_path: Path) -> None:
    truth, offset = HIDDEN["slicing"]
    _write_cut_set(tmp_path / "cuts", cut_set(truth, offset))
    measurements = load_measurement_set(tmp_path / "cuts")
    result = diagnose_set(measurements, PARAMS)
    assert result.causes == ("slicing",)
    report = result.to_json()
    assert report["causes"] == ["slicing"] and report["cut"]["causes"] == ["slicing"]
    assert report["extended"]["params"]["slicing_efficiency"] == pytest.approx(1.0, rel=0.15)
    (evidence,) = report["cut"]["evidence"]
    assert evidence["cause"] == "slicing"
    assert evidence["heldout_rmse_without_N"] > 2 * evidence["heldout_rmse_with_N"]
    low, high = evidence["params"]["slicing_efficiency"]["ci95"]
    assert low < evidence["params"]["slicing_efficiency"]["value"] < high and high - low < 0.3
    assert set(report["extended"]["fitted"]) == {"slicing_efficiency", "toughness_j_m2"}
    path = tmp_path / "material.toml"
    path.write_text(material_to_toml(result.material(), result.material_comment()))
    assert load_material(path).cutting == result.cut.extended.cutting


def test_a_set_without_tests_is_refused(tmp_path: Path) -> None:
    empty = MeasurementSet(tmp_path, None, ())
    with pytest.raises(DiagnosisError):
        diagnose_set(empty, PARAMS)


def test_the_command_diagnoses_a_cut_set_with_its_report(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    from cell.cli import main

    truth, offset = HIDDEN["blade_friction"]
    _write_cut_set(tmp_path / "cuts", cut_set(truth, offset, paths=[press(0.01), saw(0.006)]))
    out = tmp_path / "out"
    assert main(["diagnose", str(tmp_path / "cuts"), "--out", str(out / "d.json"),
                 "--report", str(out / "report"), "--workers", "1"]) == 0
    assert {p.name for p in (out / "report").iterdir()} == {"cut-forces.png", "cut-report.md"}
    assert "| blade_friction |" in (out / "report" / "cut-report.md").read_text()
    assert load_material(out / "d-material.toml").cutting.face_friction > 0.0


@pytest.mark.slow
def test_a_set_of_both_kinds_is_diagnosed_in_one_run(tmp_path: Path) -> None:
    truth, offset = HIDDEN["slicing"]
    mixed_set(tmp_path / "mixed", cut_set(truth, offset))
    measurements = load_measurement_set(tmp_path / "mixed")
    assert measurements.tests and measurements.cut_tests
    result = diagnose_set(measurements, DiagnosisParams(workers=2))
    assert result.cut.causes == ("slicing",)
    assert result.causes[-1] == "slicing" or "unexplained" in result.causes
    report = result.to_json()
    assert report["baseline"] == result.uniaxial.to_json()["baseline"]
    assert report["cut"]["causes"] == ["slicing"]
    material = result.material()
    assert material.cutting == result.cut.extended.cutting
    assert material.longitudinal == result.uniaxial.extended.material.longitudinal
