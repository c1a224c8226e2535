"""Hidden-effect log batches (:mod:`cell.synthetic.logs`): the logs read as one batch, hold
nothing of the truth, and show the hidden change (a sensor's offset, exactly; a world's
changes in the scenario the cell runs)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cell.errors import LogError
from cell.logs.batch import read_log_batch
from cell.logs.causes import changed_world
from cell.measure.logs import read_log
from cell.sim.scenario import load_scenario
from cell.synthetic.logs import world_changes, write_hidden_log_batch
from tests.paths import PROJECT_ROOT

QUICK = PROJECT_ROOT / "scenarios" / "quick.toml"


def test_a_batch_reads_as_one_and_shows_its_hidden_offset(tmp_path: Path) -> None:
    hidden = write_hidden_log_batch(tmp_path / "hidden", 5, QUICK, ("sensor_offset",), logs=2,
                                    end_s=0.06)
    plain = write_hidden_log_batch(tmp_path / "plain", 5, QUICK, (), logs=1, end_s=0.06)
    batch = read_log_batch([tmp_path / "hidden" / "log-1", tmp_path / "hidden" / "log-2"])
    assert batch.scenarios[0].tissue.length_m != batch.scenarios[1].tissue.length_m
    assert hidden.shapes[0] == plain.shapes[0]
    channel = hidden.offset_channel
    shown = (batch.logs[0].channels[channel].force_n
             - read_log(tmp_path / "plain" / "log-1").channels[channel].force_n)
    assert np.allclose(shown, hidden.magnitudes["sensor_offset"], atol=1e-9)
    text = " ".join(p.read_text() for p in (tmp_path / "hidden").rglob("*") if p.is_file())
    assert "sensor_offset" not in text
    assert repr(hidden.magnitudes["sensor_offset"][0]) not in text


def test_the_hidden_world_differs_from_the_belief_by_its_causes() -> None:
    belief = load_scenario(QUICK)
    magnitudes = {"binding_strength": 1.5, "tearing_threshold": 0.6, "tissue_stiffness": 1.3,
                  "fibre_direction": np.pi / 2, "sensor_offset": (1.0, 0.0, 0.0)}
    world = changed_world(belief, world_changes(tuple(magnitudes), magnitudes))
    assert world.aponeurosis.toughness_j_m2 == pytest.approx(
        1.5 * belief.aponeurosis.toughness_j_m2)
    assert world.aponeurosis.tearing_stretch_m == pytest.approx(
        0.6 * belief.aponeurosis.tearing_stretch_m)
    assert world.material.longitudinal.coefficients[0] == pytest.approx(
        1.3 * belief.material.longitudinal.coefficients[0])
    assert np.allclose(world.material.fibre_direction, (0.0, 1.0, 0.0), atol=1e-12)
    assert changed_world(belief, world_changes((), magnitudes)) == belief


def test_unknown_causes_are_refused(tmp_path: Path) -> None:
    with pytest.raises(LogError, match="causes"):
        write_hidden_log_batch(tmp_path, 0, QUICK, ("binding_drift",))
