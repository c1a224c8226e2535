"""The pieces of the batch diagnosis of separation logs: the causes as changes of the world
(:mod:`cell.logs.causes`), the linear algebra (:mod:`cell.logs.fit`: the closed-form
offset, the forward selection, the logs left out) and the command line's refusals."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cell.cli import main
from cell.errors import LogError
from cell.logs.batch import LogBatch
from cell.logs.causes import CAUSES, applicable, changed_world, magnitudes_json
from cell.logs.diagnosis import LogDiagnosis
from cell.logs.evidence import Indistinguishable, LogEvidence, UndeterminedBeside
from cell.logs.fit import (
    Rows,
    broyden,
    decorrelation_rows,
    forward_selection,
    heldout,
    logged_vector,
    rmse_n,
    signature,
    simulated_vector,
    solve,
    tared_samples,
)
from cell.logs.outcome import EVIDENCE_ROWS
from cell.logs.report import MATERIAL, SCENARIO, write_log_diagnosis
from cell.sim.scenario import Scenario, load_scenario
from cell.tissue.cutmodel import CuttingParams
from cell.tissue.seamcut import SeamCut, SeamLoad
from tests.logcases import wave_log
from tests.paths import PROJECT_ROOT


def test_each_world_cause_changes_its_part_of_the_world_by_its_magnitude() -> None:
    belief = Scenario()
    double = math.log(2.0)
    strong = changed_world(belief, {"binding_strength": double})
    assert strong.aponeurosis.toughness_j_m2 == pytest.approx(
        2 * belief.aponeurosis.toughness_j_m2)
    assert strong.aponeurosis.stiffness_n_m == pytest.approx(2 * belief.aponeurosis.stiffness_n_m)
    torn = changed_world(belief, {"tearing_threshold": -double})
    assert torn.aponeurosis.tearing_stretch_m == pytest.approx(
        belief.aponeurosis.tearing_stretch_m / 2)
    stiff = changed_world(belief, {"tissue_stiffness": double})
    assert np.allclose(stiff.material.longitudinal.coefficients,
                       2 * np.asarray(belief.material.longitudinal.coefficients))
    turned = changed_world(belief, {"fibre_direction": math.radians(30.0)})
    before, after = np.asarray(belief.material.fibre_direction), np.asarray(
        turned.material.fibre_direction)
    assert math.degrees(math.acos(before @ after)) == pytest.approx(30.0)
    rough = changed_world(belief, {"blade_friction": double})
    assert rough.material.cutting.face_friction == pytest.approx(
        2 * belief.material.cutting.face_friction)
    assert changed_world(belief, {}) == belief
    assert set(applicable(belief)) == set(CAUSES)
    with pytest.raises(LogError, match="unknown cause"):
        changed_world(belief, {"sensor_offset": 1.0})


def test_the_binding_gradient_is_the_scenarios_toughness_gradient_along_the_seam() -> None:
    graded = changed_world(Scenario(), {"binding_gradient": math.log(4.0)}).aponeurosis
    assert graded.toughness_gradient == pytest.approx(math.log(4.0))
    top = np.array([[-0.2, 0.0, 0.08], [0.2, 0.0, 0.08]])
    down = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
    half = np.array([0.0125, 0.0005, 0.1])

    def load(gradient: float, x: float) -> SeamLoad:
        seam = SeamCut(CuttingParams(toughness_j_m2=200.0, face_friction=0.3), top, 0.0,
                       gradient)
        return seam.load(np.array([x, 0.0, 0.105]), down, half, np.array([0.03, 0.0, 0.0]))

    # A quarter of the interface's length past its middle: 4 ** (1/4) times the toughness.
    ahead, flat = load(graded.toughness_gradient, 0.1), load(0.0, 0.1)
    assert flat.resistance_n > 0.0
    assert ahead.resistance_n / flat.resistance_n == pytest.approx(math.sqrt(2.0))
    assert load(graded.toughness_gradient, -0.1).resistance_n == pytest.approx(
        load(0.0, -0.1).resistance_n / math.sqrt(2.0))
    assert np.allclose(ahead.edge_n, math.sqrt(2.0) * flat.edge_n)
    assert np.array_equal(ahead.faces_n, flat.faces_n)  # the faces' friction is no seam's
    assert magnitudes_json({"fibre_direction": math.radians(45.0)})[
        "fibre_direction"]["angle_deg"] == pytest.approx(45.0)


def test_the_stacked_channels_and_a_sensors_offset_in_closed_form() -> None:
    offset = (0.5, -1.0, 2.0)
    logs = [wave_log(50, offset), wave_log(40, offset)]
    measured, rows = logged_vector(logs)
    simulated = np.concatenate([simulated_vector(log, wave_log(4001).channels) for log in logs])
    assert measured.size == 3 * 3 * 90 and rows.log.max() == 1
    residual = measured - simulated
    fitted, left = solve(residual, {"fixture": rows.offset_columns("fixture")})
    assert np.allclose(fitted["fixture"], offset, atol=1e-5)
    assert rmse_n(left) < 1e-4 < rmse_n(residual)
    assert rmse_n(heldout(residual, {"fixture": rows.offset_columns("fixture")}, rows)) < 1e-4
    column = rows.resting_offset(residual, "fixture")  # every sample is before a cut here
    fixture = (rows.channel == 2) & (rows.log == 0)
    assert np.allclose(column[fixture, 0][:3], offset, atol=1e-5)
    assert not column[rows.channel != 2].any()
    taken, left = solve(residual, {"rest": column}, None, frozenset({"rest"}))
    assert taken["rest"].tolist() == [1.0] and rmse_n(left) < 1e-4


def test_a_replay_is_retared_to_the_log_after_its_tare_and_an_offset_shows_before_it() -> None:
    # The replay's tare caught the ringing 1.5 N lower than the log's: a constant after it.
    log = replace(wave_log(50, (0.5, -1.0, 2.0)), sensors={"fixture_tare_s": 0.5})
    tare_draw = np.where(tared_samples(log, "fixture")[:, None], [0.0, 0.0, -1.5], 0.0)
    ours = replace(wave_log(50), channels={**wave_log(50).channels, "fixture": replace(
        wave_log(50).channels["fixture"], force_n=wave_log(50).channels["fixture"].force_n
        + tare_draw)})
    measured, rows = logged_vector([log])
    residual = measured - simulated_vector(log, ours.channels)
    after = rows.tared & (rows.channel == 2)
    assert after.sum() == 3 * 25 and not rows.tared[rows.channel != 2].any()
    assert np.allclose(residual[after].reshape(-1, 3).mean(axis=0), 0.0, atol=1e-12)
    assert np.allclose(residual[(rows.channel == 2) & ~rows.tared].reshape(-1, 3),
                       (0.5, -1.0, 2.0))
    columns = rows.offset_columns("fixture")
    assert not columns[rows.tared].any()
    fitted, left = solve(residual, {"fixture": columns})
    assert np.allclose(fitted["fixture"], (0.5, -1.0, 2.0)) and rmse_n(left) < 1e-9


def test_the_forward_selection_names_what_shows_and_nothing_else() -> None:
    rng = np.random.default_rng(0)
    n = 600
    rows = Rows(np.repeat([0, 1, 2], n // 3), np.tile(np.repeat([0, 1, 2], 3), n // 9 + 1)[:n],
                np.tile([0, 1, 2], n // 3))
    signature = np.sin(np.linspace(0.0, 30.0, n))[:, None]
    unrelated = rng.normal(size=(n, 1))
    noise = 0.05 * rng.normal(size=n)
    blocks = {"shown": signature, "unrelated": unrelated,
              "offset": rows.offset_columns("knife")}
    steps = forward_selection(0.7 * signature[:, 0] + noise, blocks, rows, 0.15)
    assert [step.added for step in steps] == ["", "shown"]
    assert forward_selection(noise, blocks, rows, 0.15)[1:] == []
    assert decorrelation_rows(noise, rows) == 1


def test_broydens_update_makes_the_signature_explain_the_replay() -> None:
    jacobian = np.array([[1.0], [0.0]])
    updated = broyden(jacobian, np.array([2.0]), np.array([4.0, 2.0]))
    assert np.allclose(updated @ [2.0], [4.0, 2.0])
    assert broyden(jacobian, np.zeros(1), np.ones(2)) is jacobian


@pytest.mark.parametrize("arguments, message", [
    (["--causes", "sensor_offset"], "--causes"), (["--workers", "0"], "--workers")])
def test_diagnose_logs_refuses_bad_options_and_writes_nothing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], arguments: list[str],
        message: str) -> None:
    out = tmp_path / "out"
    assert main(["diagnose-logs", "a", "b", "--out", str(out), "--no-plots", *arguments]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_diagnose_logs_refuses_a_batch_of_onewave_log(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    assert main(["diagnose-logs", str(tmp_path / "one"), "--out", str(out), "--no-plots"]) == 2
    assert "at least two logs" in capsys.readouterr().err
    assert not out.exists()


def test_a_causes_signature_is_the_secant_of_the_side_it_acts_on() -> None:
    up, down = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 1.0])
    residual = 0.5 * down  # the cause acts only when lowered: here by 0.5 (magnitude -0.5)
    sides = [(0.3, 0.3 * up), (-0.3, -0.3 * -down)]
    chosen = signature(residual, sides)
    assert np.allclose(chosen[:, 0], -down)
    assert signature(residual, [(0.3, None)]) is None


def test_the_report_and_the_extended_world_a_user_runs_next(tmp_path: Path) -> None:
    quick = PROJECT_ROOT / "scenarios" / "quick.toml"
    logs = tuple(replace(wave_log(30), scenario=quick, name=f"log-{k}") for k in (1, 2))
    batch = LogBatch(logs, (load_scenario(quick),) * 2)
    measured, _ = logged_vector(logs, EVIDENCE_ROWS)
    strength = magnitudes_json({"binding_strength": math.log(1.5),
                                "binding_gradient": math.log(2.0)})
    evidence = [LogEvidence("binding_strength", 1.0, 1.8, 1.0, {}, None),
                LogEvidence("sensor_offset", 1.0, 1.2, 0.5, {}, None, channel="knife")]
    diagnosis = LogDiagnosis(
        ["log-1", "log-2"], [1.0, 1.0], ["binding_strength", "binding_gradient",
                                         "sensor_offset"], [],
        {"params": {**strength, "sensor_offset": {"knife": [0.5, 0.0, 0.0]}},
         "pruned": [{"cause": "tissue_stiffness", "magnitude": 0.068, "factor": 1.07,
                     "rmse_N": 0.52, "with_rmse_N": 0.5}]},
        {"baseline": 2.0, "extended": 1.0}, evidence, [],
        {"baseline": measured + 1.0, "extended": measured + 0.1, "measured": measured},
        {"replays": 9, "replays_by_round": {"screening": 9}, "replay_wall_s": 1.0,
         "fit_s": 0.1, "total_s": 1.1},
        indistinguishable=[Indistinguishable("binding_strength", "tearing_threshold", 1.0, 1.05,
                                             "gripper")],
        undetermined_beside=[UndeterminedBeside("binding_stiffness", ("binding_strength",),
                                                -0.2, 0.9, "outcome")])
    written = write_log_diagnosis(tmp_path / "out", batch, diagnosis, plots=True)
    assert {p.name for p in written} >= {"diagnosis.json", "report.md", "channels-1.png",
                                         SCENARIO, MATERIAL}
    extended = load_scenario(tmp_path / "out" / SCENARIO)
    assert extended.aponeurosis.toughness_j_m2 == pytest.approx(
        1.5 * batch.scenarios[0].aponeurosis.toughness_j_m2)
    assert extended.material == batch.scenarios[0].material
    assert extended.aponeurosis.toughness_gradient == pytest.approx(math.log(2.0))
    header = [line for line in (tmp_path / "out" / SCENARIO).read_text().splitlines()
              if line.startswith("# Not in")]
    assert header == ["# Not in a scenario's keys: sensor_offset (see diagnosis.json)"]
    assert diagnosis.gain == pytest.approx(0.5)
    report = (tmp_path / "out" / "report.md").read_text()
    assert "gain 0.50" in report and "- sensor_offset (knife): held-out 1.000 N" in report
    assert ("- binding_strength cannot be told from tearing_threshold on these logs: held-out "
            "1.000 N against 1.050 N (linearised); they differ most in the gripper force"
            in report)
    assert ("- binding_stiffness may be changed as well: beside binding_strength, refitted, "
            "these logs allow it from 0.819 times to 2.46 times (linearised); its change "
            "differs most in the outcome (the counts and the release times)" in report)
    assert ("- tissue_stiffness left out of the fit: the replays fit 0.520 N without it, "
            "0.500 N with it" in report)
    data = json.loads((tmp_path / "out" / "diagnosis.json").read_text())
    assert {"causes", "candidates", "steps", "evidence", "gain", "noise_N", "baseline",
            "extended", "second_look", "indistinguishable"} <= set(data)
    assert data["indistinguishable"][0]["differs_most"] == "gripper"
    assert data["undetermined_beside"][0]["beside"] == ["binding_strength"]
    assert data["evidence"][1] == {"cause": "sensor_offset", "heldout_rmse_with_N": 1.0,
                                   "heldout_rmse_without_N": 1.2, "improved_fraction": 0.5,
                                   "params": {}, "channel": "knife", "linearised": True}
