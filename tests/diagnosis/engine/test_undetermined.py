"""A diagnosis is never stopped by its own numbers: what a fit does not determine (a parameter
the tests do not bound, a score of a prediction that did not stay finite) is ``null`` with its
reason in the JSON and "not determined" in the report, in the uniaxial, the cut and the log
diagnoses alike (:mod:`cell.diagnosis.engine.determined`), and the command ends with exit 0."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import pytest

from cell.cli import main
from cell.diagnosis.cut.causes import CutCandidate
from cell.diagnosis.cut.fitting import CutProblem, fit_cut
from cell.diagnosis.engine.determined import NOT_IDENTIFIABLE, NOT_IN_LOGS, NOT_PREDICTED
from cell.logs.batch import LogBatch
from cell.logs.causes import magnitudes_json
from cell.logs.diagnosis import LogDiagnosis
from cell.logs.fit import logged_vector
from cell.logs.report import write_log_diagnosis
from cell.outputs import json_text
from cell.sim.scenario import load_scenario
from cell.synthetic.specimen import Repeats, write_hidden_effect_set
from tests.cutsets import BLADE, BLOCK, PLAIN, cut_set, press
from tests.logcases import wave_log
from tests.paths import PROJECT_ROOT

#: A set the generator draws with plasticity (little hardening) beside viscoelasticity: its
#: first six tests (ramps at three angles in tension, two in compression, one ten times
#: faster: no relaxation hold), every fourth sample. Diagnosed before, the relaxation's
#: intervals came out NaN and stopped the command with exit 3, nothing written.
SEED, CONDITIONS, EVERY = 1000, 6, 4


@pytest.fixture(scope="module")
def ramps_without_holds(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The set the constants above draw, alone in a parent folder."""
    folder = tmp_path_factory.mktemp("undetermined") / "sets" / "plastic-viscoelastic"
    write_hidden_effect_set(folder, SEED, ("plasticity", "viscoelasticity"),
                            repeats=Repeats(CONDITIONS, 1))
    lines = (folder / "tests.csv").read_text().splitlines()
    header, rows = lines[0], lines[1:]
    seen: dict[str, int] = {}
    kept = []
    for row in rows:
        test = row.split(",")[0]
        seen[test] = seen.get(test, -1) + 1
        if seen[test] % EVERY == 0:
            kept.append(row)
    (folder / "tests.csv").write_text("\n".join([header, *kept]) + "\n")
    return folder


@pytest.mark.slow  # a whole diagnosis; the default run's check: tests/diagnosis/engine/test_fuzz.py
def test_a_diagnosis_completes_and_reports_an_interval_the_tests_do_not_bound(
        ramps_without_holds: Path, tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    out = tmp_path / "diagnosis.json"
    assert main(["diagnose", str(ramps_without_holds), "--json", str(out), "--report",
                 str(tmp_path / "report"), "--workers", "1"]) == 0
    result = json.loads(out.read_text())
    assert result["causes"][:2] == ["plasticity", "viscoelasticity"]
    relaxation = result["evidence"][1]["params"]
    undetermined = {name for name, entry in relaxation.items() if entry["ci95"] is None}
    assert undetermined, "no relaxation hold: the tests do not bound the relaxation"
    assert all(relaxation[name]["ci95_reason"] == NOT_IDENTIFIABLE for name in undetermined)
    assert all(math.isfinite(entry["value"]) for entry in relaxation.values())
    low, high = result["evidence"][0]["params"]["yield_strain"]["ci95"]
    assert low < result["evidence"][0]["params"]["yield_strain"]["value"] < high
    assert "[interval not determined: not identifiable from these tests]" in (
        tmp_path / "report" / "report.md").read_text()


@pytest.mark.slow  # the set of the test above, diagnosed again as a batch
def test_the_batch_diagnoses_it_too(ramps_without_holds: Path, tmp_path: Path) -> None:
    out = tmp_path / "batch"
    assert main(["diagnose", "--batch", str(ramps_without_holds.parent), "--out", str(out),
                 "--workers", "1", "--quiet"]) == 0
    result = json.loads((out / "sets" / "plastic-viscoelastic.json").read_text())
    assert result["causes"][:2] == ["plasticity", "viscoelasticity"]
    assert any(entry["ci95"] is None for entry in result["evidence"][1]["params"].values())


def test_a_cut_parameter_no_test_moves_has_no_interval_and_says_why() -> None:
    # Pressed cuts never move the edge along itself: slicing does nothing to them.
    problem = CutProblem.of(BLOCK, BLADE, cut_set(PLAIN, paths=[press(0.01), press(0.01, 0.015)]),
                            64)
    model = CutCandidate(("slicing",), problem.reference_speed_m_s(), BLOCK.top_z_m)
    fitted = fit_cut(problem, model, model.initial, 100).to_json()["fitted"]
    assert fitted["slicing_efficiency"]["ci95"] is None
    assert fitted["slicing_efficiency"]["ci95_reason"] == NOT_IDENTIFIABLE
    low, high = fitted["toughness_j_m2"]["ci95"]
    assert low < 900.0 < high
    json_text(fitted, "cut.json")  # strict: no NaN reaches the writer


def test_a_log_magnitude_past_any_factor_and_an_unpredicted_score_are_null(
        tmp_path: Path) -> None:
    quick = PROJECT_ROOT / "scenarios" / "quick.toml"
    logs = tuple(replace(wave_log(30), scenario=quick, name=f"log-{k}") for k in (1, 2))
    batch = LogBatch(logs, (load_scenario(quick),) * 2)
    measured, _ = logged_vector(logs)
    # A signature the logs barely show gives a linearised magnitude whose factor no float holds.
    unbounded = magnitudes_json({"tissue_stiffness": 1e3})["tissue_stiffness"]
    diagnosis = LogDiagnosis(
        ["log-1", "log-2"], [1.0, 1.0], [],
        [{"cause": "tissue_stiffness", "heldout_rmse_N": math.inf, "selected": False,
          "linearised": True, "params": unbounded}],
        {"params": {}, "rmse_N": 1.0}, {"baseline": 2.0, "extended": 2.0}, {}, [],
        {"baseline": measured + 1.0, "extended": measured + 1.0, "measured": measured},
        {"replays": 9, "replays_by_round": {"screening": 9}, "replay_wall_s": 1.0,
         "fit_s": 0.1, "total_s": 1.1})
    write_log_diagnosis(tmp_path / "out", batch, diagnosis, plots=False)
    (candidate,) = json.loads((tmp_path / "out" / "diagnosis.json").read_text())["candidates"]
    assert candidate["params"] == {"magnitude": 1e3, "factor": None,
                                   "factor_reason": NOT_IN_LOGS}
    assert candidate["heldout_rmse_N"] is None
    assert candidate["heldout_rmse_N_reason"] == NOT_PREDICTED
    assert "| tissue_stiffness | magnitude 1e+03, factor not determined | not determined |" in (
        tmp_path / "out" / "report.md").read_text()
