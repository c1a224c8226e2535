"""Adding a cause to the log diagnosis: a toy cause, a module's worth of code here and one
registration line, is screened, applied, written into the extended scenario, hidden by the
generator and cycled through by the bench, with nothing else edited."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import pytest

from cell.bench.diagnose_logs import hidden, log_pairs, log_table
from cell.logs.batch import LogBatch
from cell.logs.causes import CAUSES, LogCause, applicable, changed_world, magnitudes_json
from cell.logs.diagnosis import LogDiagnosis
from cell.logs.report import SCENARIO, write_log_diagnosis
from cell.logs.search import screening_worlds
from cell.sim.scenario import Scenario, load_scenario
from cell.synthetic.logs import _draw_world, hidden_causes, write_hidden_log_batch
from tests.logcases import wave_log
from tests.paths import PROJECT_ROOT

QUICK = PROJECT_ROOT / "scenarios" / "quick.toml"


@dataclass(frozen=True)
class BindingDamping(LogCause):
    """The toy: the bindings' dashpot times ``exp(m)``."""

    def change(self, scenario: Scenario, magnitude: float) -> Scenario:
        apo = scenario.aponeurosis
        return replace(scenario, aponeurosis=replace(
            apo, damping_n_s_m=apo.damping_n_s_m * math.exp(magnitude)))


TOY = BindingDamping("binding_damping", step=0.5)


@pytest.fixture
def registered(monkeypatch: pytest.MonkeyPatch) -> None:
    """The registration line, for this test only."""
    monkeypatch.setitem(CAUSES, TOY.name, TOY)


def test_a_registered_cause_is_screened_and_changes_the_world(registered: None) -> None:
    belief = Scenario()
    assert TOY.name in applicable(belief)
    world = changed_world(belief, {TOY.name: math.log(2.0)})
    assert world.aponeurosis.damping_n_s_m == pytest.approx(
        2 * belief.aponeurosis.damping_n_s_m)
    assert screening_worlds([TOY.name], {}) == [{TOY.name: 0.5}, {TOY.name: -0.5}]
    assert magnitudes_json({TOY.name: math.log(2.0)})[TOY.name]["factor"] == pytest.approx(2.0)


def test_the_report_writes_a_registered_causes_change_into_the_extended_scenario(
        registered: None, tmp_path: Path) -> None:
    logs = tuple(replace(wave_log(30), scenario=QUICK, name=f"log-{k}") for k in (1, 2))
    batch = LogBatch(logs, (load_scenario(QUICK),) * 2)
    diagnosis = LogDiagnosis(
        ["log-1", "log-2"], [1.0, 1.0], [TOY.name], [],
        {"params": magnitudes_json({TOY.name: math.log(3.0)})},
        {"baseline": 2.0, "extended": 1.0}, [], [], {},
        {"replays": 9, "replays_by_round": {"screening": 9}, "replay_wall_s": 1.0, "fit_s": 0.1,
         "total_s": 1.1})
    write_log_diagnosis(tmp_path / "out", batch, diagnosis, plots=False)
    extended = load_scenario(tmp_path / "out" / SCENARIO)
    assert extended.aponeurosis.damping_n_s_m == pytest.approx(
        3 * batch.scenarios[0].aponeurosis.damping_n_s_m)
    assert f"{TOY.name} (magnitude" in (tmp_path / "out" / "report.md").read_text()


def test_the_generator_hides_and_the_bench_cycles_through_a_registered_cause(
        registered: None, tmp_path: Path) -> None:
    assert TOY.name in hidden_causes()
    assert log_table()[-2:] == (TOY.name, "sensor_offset")
    assert (TOY.name, "sensor_offset") in log_pairs()
    assert hidden(70_000 + log_table().index(TOY.name), "single") == (TOY.name,)
    drawn, channel, _ = _draw_world(3)
    low, high = TOY.typical
    assert low <= max(drawn[TOY.name], 1 / drawn[TOY.name]) <= high
    with pytest.MonkeyPatch.context() as unregistered:
        unregistered.delitem(CAUSES, TOY.name)
        before, before_channel, _ = _draw_world(3)
    assert {k: v for k, v in drawn.items() if k != TOY.name} == before  # old seeds unchanged
    assert channel == before_channel
    truth = write_hidden_log_batch(tmp_path / "batch", seed=1, base=QUICK, causes=(TOY.name,),
                                   logs=1, end_s=0.04)
    assert truth.causes == (TOY.name,) and TOY.name in truth.magnitudes
