"""``specimen_variability``: repeats recognised from the tests themselves, the spread between
them fitted as a random effect, named when repeats disagree beyond the noise and not when they
agree."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.specimen.causes import CandidateMaterial
from cell.diagnosis.specimen.diagnosis import diagnose, noise_n
from cell.diagnosis.specimen.fitting import Problem, fit
from cell.diagnosis.specimen.planeseries import PlaneSeries
from cell.diagnosis.specimen.repeats import repeat_groups
from cell.diagnosis.specimen.spread import specimen_spread
from cell.measure.shearbiaxial import BiaxialTest
from cell.measure.specimens import MeasurementSet, Specimen, load_measurement_set
from cell.synthetic.specimen import Repeats, write_hidden_effect_set

# Five ramps of the hidden-effect protocol, three specimens each.
_SMALL = (5, 3)


def _small_set(folder: Path, seed: int, spread_sd: float) -> MeasurementSet:
    write_hidden_effect_set(folder, seed, None, repeats=Repeats(*_SMALL, spread_sd))
    return load_measurement_set(folder)


def test_repeats_are_found_when_the_names_are_shuffled(tmp_path: Path) -> None:
    data = _small_set(tmp_path / "set", 3, 0.2)
    order = np.random.default_rng(0).permutation(len(data.tests))
    shuffled = tuple(replace(data.tests[i], test_id=f"specimen-{k:02d}")
                     for k, i in enumerate(order))
    groups = repeat_groups(shuffled, data.specimen)
    # The generator names repeat k of condition c "<c>-<k>": the truth, hidden from the grouping.
    def condition(test_index: int) -> str:
        return data.tests[test_index].test_id.rsplit("-", 1)[0]

    found = sorted(sorted(condition(order[i]) for i in g) for g in groups)
    assert found == sorted([c] * 3 for c in {condition(i) for i in range(len(data.tests))})
    assert len(found) == 5


def test_biaxial_stretches_in_other_ratios_are_other_conditions() -> None:
    time = np.linspace(0.0, 20.0, 41)
    ramp = 1e-3 * time / time[-1]
    specimen = Specimen("cube", (0.01,) * 3)
    tests = tuple(PlaneSeries(BiaxialTest(name, 0.0, time, z * ramp, x * ramp, 0 * time,
                                          0 * time), specimen.size_m)
                  for name, z, x in (("1:1", 1.0, 1.0), ("1:0.5", 1.0, 0.5), ("0.5:1", 0.5, 1.0),
                                     ("1:1 again", 1.0, 1.0)))
    assert repeat_groups(tests, specimen) == [[0, 3], [1], [2]]


def _spread_of_baseline_fit(data: MeasurementSet):
    """The spread about a fit of the linear springs (the truth's own law: no effect hidden)."""
    problem = Problem.of(data.specimen, data.tests, 32)
    model = CandidateMaterial(())
    fitted = fit(problem, model, model.initial, 10)
    return specimen_spread(data.tests, fitted.fitted_force_n, fitted.offset_n, noise_n(data),
                           repeat_groups(data.tests, data.specimen))


def test_a_spread_between_repeats_is_named_and_fitted(tmp_path: Path) -> None:
    spread = _spread_of_baseline_fit(_small_set(tmp_path / "set", 4, 0.2))
    assert spread.named
    assert 0.2 * 0.6 < spread.sd < 0.2 * 1.5
    assert spread.ci95[0] < spread.sd < spread.ci95[1]
    assert len(spread.groups) == 5


def test_repeats_that_agree_name_no_spread(tmp_path: Path) -> None:
    spread = _spread_of_baseline_fit(_small_set(tmp_path / "set", 4, 0.0))
    assert not spread.named
    assert spread.sd < 0.02


@pytest.mark.slow
def test_diagnosis_names_the_spread_with_intervals(tmp_path: Path) -> None:
    result = diagnose(_small_set(tmp_path / "set", 5, 0.2), DiagnosisParams(workers=2))
    assert result.causes == ("specimen_variability",)
    assert abs(result.specimen.sd - 0.2) <= 0.35 * 0.2
    report = result.to_json()
    assert report["specimen_variability"]["named"]
    assert 0.75 <= report["intervals"]["coverage"] <= 1.0
    from cell.diagnosis.specimen.report import write_report

    markdown = write_report(result, tmp_path / "report")[-1].read_text()
    assert "## Specimens and predictions with intervals" in markdown
    assert "5 groups of tests under equal conditions" in markdown


def _row(kind: str, named: bool, coverage: float, truth: float, fitted: float) -> dict:
    return {"seed": 1, "kind": kind, "causes": ["specimen_variability"] if named else [],
            "spread_named": named, "spread_sd_truth": truth, "spread_sd_fitted": fitted,
            "spread_within_35pc": truth > 0 and abs(fitted - truth) <= 0.35 * truth,
            "material_causes_correct": True, "coverage": coverage, "seconds": 10.0}


def test_the_spread_bench_judges_its_targets() -> None:
    from cell.bench.spread import summarize

    rows = [_row("spread", True, 0.9, 0.2, 0.21), _row("spread", True, 0.88, 0.1, 0.2),
            _row("no_spread", False, 0.99, 0.0, 0.0), _row("no_spread", True, 0.97, 0.0, 0.03)]
    targets = summarize(rows, 2, [1])["targets"]
    assert targets["named_with_spread"]["pass"]
    assert not targets["named_without_spread"]["pass"]
    assert not targets["spread_within_35pc"]["pass"]
    assert targets["spread_coverage_median"]["pass"]
    assert not targets["no_spread_coverage_median"]["pass"]


def test_only_the_diagnose_bench_takes_spread() -> None:
    from cell.cli import main

    assert main(["bench", "env", "--spread"]) == 2
