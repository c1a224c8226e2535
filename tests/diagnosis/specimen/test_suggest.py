"""The next test to run (``musclecell diagnose --suggest``): the candidate tests drawn up from a
set, the rivals a set cannot exclude, the test that tells them apart, the bench's ambiguous
sets, and the command line's refusals.

Seeds below the benches' (10 000).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cell.bench.suggestbench import MISSING, add_test, missing_kind, write_ambiguous_set
from cell.cli import main
from cell.diagnosis.specimen.causes import CandidateMaterial
from cell.diagnosis.specimen.diagnosis import Diagnosis, noise_n
from cell.diagnosis.specimen.fitting import Problem, fit
from cell.diagnosis.specimen.nexttests import CandidateTest, candidate_tests
from cell.diagnosis.specimen.suggest import suggest
from cell.measure.protocols import ramp
from cell.measure.specimens import (
    MeasurementSet,
    MechanicalTest,
    Specimen,
    load_measurement_set,
)
from tests.paths import EXAMPLE_SET

CUBE = Specimen("cube", (0.01, 0.01, 0.01))


def test_the_candidates_hold_every_mode_angle_sign_and_two_rates() -> None:
    candidates = candidate_tests(load_measurement_set(EXAMPLE_SET))
    assert {c.mode for c in candidates} == {"tension", "compression", "relaxation", "cyclic"}
    assert {c.angle_deg for c in candidates} == {0.0, 45.0, 90.0}
    assert min(c.strain for c in candidates) < 0.0 < max(c.strain for c in candidates)
    ramps = {c.rate_per_s for c in candidates if c.mode == "tension"}
    assert len(ramps) == 2 and max(ramps) == pytest.approx(10.0 * min(ramps))
    assert all(c.hold_s > 0.0 for c in candidates if c.mode == "relaxation")


def test_a_candidate_is_a_plan_and_a_test_to_simulate() -> None:
    test = CandidateTest("cyclic", 90.0, -0.1, 0.01)
    plan = test.plan("next")
    assert plan.strain().min() == pytest.approx(-0.1) and plan.strain()[-1] == 0.0
    run = test.mechanical_test(CUBE)
    assert run.mode == "cyclic" and run.displacement_m.min() == pytest.approx(-0.001)
    assert test.to_json()["description"].endswith("90 deg to the fibres")


def _tension_only_set() -> MeasurementSet:
    """Two ramps in tension along the fibres of a linear isotropic truth (with noise): a set
    that cannot tell an asymmetry, nor an anisotropy, from none."""
    rng = np.random.default_rng(3)
    tests = []
    for k, rate in enumerate((0.01, 0.1)):
        plan = ramp(f"t{k}", "tension", 0.0, 0.12, rate, 40)
        strain = plan.strain()
        force = 1e4 * strain * CUBE.area_m2 + rng.normal(0.0, 2e-4, strain.shape)
        tests.append(MechanicalTest(plan.test_id, "tension", 0.0, plan.time_s,
                                    strain * CUBE.size_m[2], force))
    return MeasurementSet(Path("tension-only"), CUBE, tuple(tests))


def test_a_set_in_tension_alone_gets_a_test_that_compresses_or_turns_the_fibres() -> None:
    data = _tension_only_set()
    problem = Problem.of(data.specimen, data.tests, 32)
    model = CandidateMaterial((), stretch_range=(0.8, 1.2))
    baseline = fit(problem, model, model.initial, 50)
    diagnosis = Diagnosis(data, noise_n(data), baseline, (), (), baseline, (),
                          explored=(baseline,))
    suggestion = suggest(diagnosis)
    assert suggestion.ambiguous
    assert {r.typical for r in suggestion.rivals} >= {"anisotropy",
                                                       "tension_compression_asymmetry"}
    assert suggestion.test is not None
    assert suggestion.test.strain < 0.0 or suggestion.test.angle_deg != 0.0
    assert suggestion.over_scatter > 3.0
    report = suggestion.to_json()
    assert report["test"]["mode"] == suggestion.test.mode
    assert report["predicted_difference_N"] == pytest.approx(suggestion.difference_n)
    assert len(report["ranking"]) == 5 and "times the scatter" in suggestion.summary()


@pytest.mark.parametrize("seed", [9000, 9001, 9002, 9003])
def test_an_ambiguous_set_lacks_its_evidence_and_takes_a_test_run_on_its_truth(
        tmp_path: Path, seed: int) -> None:
    missing = MISSING[missing_kind(seed)]
    truth = write_ambiguous_set(tmp_path, seed)
    assert truth.effects == (missing.effect,)
    data = load_measurement_set(tmp_path)
    for test in data.tests:
        assert not missing.drops(test.mode, test.angle_deg, float(test.displacement_m.min()),
                                 test.test_id)
    add_test(tmp_path, truth, CandidateTest("compression", 90.0, -0.1, 0.01), "next",
             np.random.default_rng(0))
    again = load_measurement_set(tmp_path)
    assert len(again.tests) == len(data.tests) + 1
    added = again.test("next")
    assert added.mode == "compression" and added.force_n.min() < 0.0


def test_the_kinds_of_missing_evidence_come_in_turn() -> None:
    assert {missing_kind(s) for s in range(4)} == {"compression", "angles", "holds", "cycles"}


@pytest.mark.parametrize(("argv", "named"), [
    (["bench", "diagnose", "--including", "force_offset"], ["--including", "--pairs"]),
    (["bench", "diagnose", "--pairs", "--including", "glue"], ["--including", "glue"]),
    (["bench", "diagnose", "--pairs", "--triples"], ["--triples", "not both"]),
    (["bench", "diagnose", "--cut", "--triples"], ["--triples", "cut"]),
    (["bench", "cell", "--suggest"], ["--suggest", "bench diagnose"]),
    (["diagnose", "--batch", "sets", "--out", "o", "--suggest"], ["--suggest"]),
])
def test_bad_flags_are_refused_naming_them(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                           capsys: pytest.CaptureFixture, argv: list[str],
                                           named: list[str]) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sets").mkdir()
    assert main(argv) == 2
    message = capsys.readouterr().err
    assert "Traceback" not in message
    for name in named:
        assert name in message, message
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sets"]


def test_suggest_on_cut_tests_alone_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                               capsys: pytest.CaptureFixture) -> None:
    monkeypatch.chdir(tmp_path)
    cut_set = EXAMPLE_SET.parent / "beef_cut_example"
    assert main(["diagnose", str(cut_set), "--out", "d.json", "--suggest"]) == 2
    message = capsys.readouterr().err
    assert "tests.csv" in message and "--suggest" in message
    assert not any(tmp_path.iterdir())


@pytest.mark.slow
def test_the_suggest_bench_runs_on_one_set() -> None:
    from cell.bench.suggestbench import run_suggest_bench

    report = run_suggest_bench([9000], workers=1)
    assert {"named_after_suggested", "named_after_random", "suggest_time",
            "diagnose_suggest_seconds_max", "suggested_beats_random"} <= (
                report["targets"].keys() | report["entries"].keys())
    entry = report["sets"][0]
    assert entry["missing"] == "compression" and entry["suggested"]["test"]["mode"]
    assert "| missing |" in report["markdown"]
