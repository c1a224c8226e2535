"""Adding a cause to a family is one cause object and one registration line: with a toy cause
registered, the specimen and the cut diagnoses fit it beside the catalogue's causes and, on a
set without its effect, name what they named without it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from cell.diagnosis.cut import causes as cut_causes
from cell.diagnosis.cut.causes.base import CutCause, CutSettings
from cell.diagnosis.cut.search import diagnose_cuts
from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.specimen import causes as specimen_causes
from cell.diagnosis.specimen.causes.base import Cause, Parameter, Settings
from cell.diagnosis.specimen.diagnosis import diagnose
from cell.measure.specimens import load_measurement_set
from cell.synthetic.specimen import Repeats, write_hidden_effect_set
from tests.cutsets import BLADE, BLOCK, PLAIN, cut_set

PARAMS = DiagnosisParams(workers=1)


class SpringDamping(Cause):
    """A toy cause: the springs' damping time, a factor 10^d of the default."""

    name = "spring_damping"

    def parameters(self, model: Settings) -> tuple[Parameter, ...]:
        return (Parameter("log_damping_factor", 0.0, -1.0, 1.0),)

    def fields(self, value: dict[str, float], model: Settings) -> dict[str, Any]:
        return {"damping_s": 2.0e-4 * 10.0 ** value["log_damping_factor"]}


class BluntEdge(CutCause):
    """A toy cause: the edge loads the material over a depth before the crack runs."""

    name = "blunt_edge"

    def parameters(self, model: CutSettings) -> tuple[Parameter, ...]:
        return (Parameter("bluntness_m", 0.1 * model.depth_m, 1e-5, 0.5 * model.depth_m),)

    def fields(self, value: dict[str, float]) -> dict[str, Any]:
        return {"loading_depth_m": value["bluntness_m"]}


@pytest.mark.slow
def test_a_specimen_cause_added_runs_and_names_nothing_else(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    folder = tmp_path / "anisotropic"
    write_hidden_effect_set(folder, 1001, "anisotropy", repeats=Repeats(4, 1))
    measurements = load_measurement_set(folder)
    monkeypatch.setitem(specimen_causes.REGISTRY, SpringDamping.name, SpringDamping())
    result = diagnose(measurements, PARAMS)
    assert any(SpringDamping.name in fit.model.causes for fit in result.candidates)
    assert result.causes == ("anisotropy",)


def test_a_cut_cause_added_runs_and_names_nothing_else(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(cut_causes.REGISTRY, BluntEdge.name, BluntEdge())
    result = diagnose_cuts(BLOCK, BLADE, cut_set(PLAIN, (0.5, -0.3, 2.0)), PARAMS)
    assert any(BluntEdge.name in fit.model.causes for fit in result.candidates)
    assert result.causes == ("blade_force_offset",)
