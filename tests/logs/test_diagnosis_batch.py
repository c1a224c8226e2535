"""The batch diagnosis of separation logs end to end (slow: it replays the cell a few dozen
times): a batch whose world hides a binding strength is diagnosed as such, with the
contract's keys, and the extended scenario it writes runs as an episode; a sensor's hidden
offset is fitted in closed form."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cell.cli import main
from cell.logs.batch import read_log_batch
from cell.logs.causes import CAUSES
from cell.logs.diagnosis import LogDiagnosisParams, diagnose_logs
from cell.synthetic.logs import write_hidden_log_batch
from tests.paths import PROJECT_ROOT

QUICK = PROJECT_ROOT / "scenarios" / "quick.toml"
#: A batch seed whose drawn binding strength is well away from the belief's.
SEED = 11


@pytest.mark.slow
def test_a_hidden_binding_strength_is_named_and_its_world_runs(tmp_path: Path) -> None:
    truth = write_hidden_log_batch(tmp_path / "batch", SEED, QUICK, ("binding_strength",))
    logs = [str(tmp_path / "batch" / f"log-{k}") for k in (1, 2, 3)]
    out = tmp_path / "diagnosis"
    assert main(["diagnose-logs", *logs, "--out", str(out), "--no-plots", "--workers",
                 "2"]) == 0
    data = json.loads((out / "diagnosis.json").read_text())
    assert {"baseline", "causes", "candidates", "extended", "gain"} <= set(data)
    assert data["causes"] == ["binding_strength"]
    fitted = data["extended"]["params"]["binding_strength"]["factor"]
    assert fitted == pytest.approx(truth.magnitudes["binding_strength"], rel=0.2)
    assert data["extended"]["heldout_rmse_N"] < data["baseline"]["heldout_rmse_N"]
    assert data["gain"] > 0.0
    screening = 3 * (1 + sum(len(cause.probes(True)) for cause in CAUSES.values()))
    # Beyond the screening: the fit's start and steps, each log held out, a second look.
    assert data["timing"]["replays"] <= screening + 60
    assert (out / "report.md").is_file() and (out / "extended-material.toml").is_file()
    assert main(["run", str(out / "extended-scenario.toml"), "--quiet"]) == 0


@pytest.mark.slow
def test_a_hidden_sensor_offset_is_fitted_in_closed_form(tmp_path: Path) -> None:
    truth = write_hidden_log_batch(tmp_path / "batch", 5, QUICK, ("sensor_offset",), logs=2)
    batch = read_log_batch([tmp_path / "batch" / "log-1", tmp_path / "batch" / "log-2"])
    diagnosis = diagnose_logs(batch, LogDiagnosisParams(workers=1, causes=("tissue_stiffness",)))
    assert diagnosis.causes == ["sensor_offset"]
    offset = diagnosis.extended["params"]["sensor_offset"]
    assert list(offset) == [truth.offset_channel]
    assert np.allclose(offset[truth.offset_channel], truth.magnitudes["sensor_offset"], atol=0.3)
    # The lab's world and the cause's four screening probes (near and wide), per log.
    assert diagnosis.timing["replays"] == 2 * (1 + len(CAUSES["tissue_stiffness"].probes(True)))
    assert diagnosis.gain > 0.2  # the replays' own misfit and the noise stay
