"""``specimen_variability`` across named specimens: a spread between specimens is named and
fitted, none is not, a test is predicted by the other specimens alone, and a set whose tests
all name one specimen is diagnosed as before."""

from __future__ import annotations

import csv
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.specimen.causes import CandidateMaterial
from cell.diagnosis.specimen.diagnosis import diagnose, noise_n
from cell.diagnosis.specimen.fitting import ModelFit, Problem, fit
from cell.diagnosis.specimen.repeats import repeat_groups
from cell.diagnosis.specimen.specimenids import specimen_folds, spread_by_specimen
from cell.measure.specimens import MeasurementSet, load_measurement_set
from cell.synthetic.specimen import HiddenEffect, Repeats, write_hidden_effect_set

# Five ramps of the hidden-effect protocol, run by each of four named specimens.
_CONDITIONS, _SPECIMENS = 5, 4


def _named_set(folder: Path, seed: int, spread_sd: float) -> tuple[MeasurementSet, HiddenEffect]:
    truth = write_hidden_effect_set(folder, seed, None,
                                    repeats=Repeats(_CONDITIONS, _SPECIMENS, spread_sd, named=True))
    return load_measurement_set(folder), truth


def _baseline_fit(data: MeasurementSet) -> ModelFit:
    """The linear springs (the truth's own law: no effect hidden), held out as the set says."""
    problem = Problem.of(data.specimen, data.tests, 32, specimen_folds(data.tests))
    return fit(problem, CandidateMaterial(()), np.zeros(0), 10)


def _spread(data: MeasurementSet):
    fitted = _baseline_fit(data)
    return spread_by_specimen(data.tests, fitted.fitted_force_n, fitted.offset_n, noise_n(data),
                              repeat_groups(data.tests, data.specimen),
                              specimen_folds(data.tests))


def test_a_spread_between_named_specimens_is_named_and_fitted(tmp_path: Path) -> None:
    data, truth = _named_set(tmp_path / "set", 11, 0.2)
    spread = _spread(data)
    realised = float(np.std(np.log(truth.specimen_factors[:_SPECIMENS]), ddof=1))
    assert spread.named
    assert abs(spread.sd - realised) <= 0.35 * realised
    assert spread.ci95[0] < spread.sd < spread.ci95[1]
    # Each specimen's factor, relative to the population's, against the truth's.
    fitted = np.log([spread.specimens[f"S{k + 1}"].factor for k in range(_SPECIMENS)])
    drawn = np.log(truth.specimen_factors[:_SPECIMENS])
    assert np.allclose(fitted - fitted.mean(), drawn - drawn.mean(), atol=0.02)
    assert all(f.low < f.factor < f.high for f in spread.specimens.values())
    entry = spread.to_json()["by_specimen"]
    assert entry["held_out"] == "leave-one-specimen-out"
    assert sorted(entry["specimens"]) == ["S1", "S2", "S3", "S4"]


def test_named_specimens_that_agree_name_no_spread(tmp_path: Path) -> None:
    spread = _spread(_named_set(tmp_path / "set", 11, 0.0)[0])
    assert not spread.named
    assert spread.sd < 0.02


def _scaled(data: MeasurementSet, specimen: str, factor: float) -> MeasurementSet:
    tests = tuple(replace(t, force_n=t.force_n * factor) if t.specimen_id == specimen else t
                  for t in data.tests)
    return replace(data, tests=tests)


def test_a_test_is_predicted_by_the_other_specimens_alone(tmp_path: Path) -> None:
    data, _ = _named_set(tmp_path / "set", 12, 0.1)
    before = _baseline_fit(data).heldout_force_n
    after = _baseline_fit(_scaled(data, "S1", 3.0)).heldout_force_n
    for test, old, new in zip(data.tests, before, after, strict=True):
        # S1's own tests never predict each other; every other test sees S1 changed.
        assert np.allclose(old, new, rtol=1e-9) == (test.specimen_id == "S1")


def _one_specimen(source: Path, folder: Path) -> None:
    """The set of ``source`` with every test naming specimen S1."""
    folder.mkdir()
    (folder / "specimen.toml").write_text((source / "specimen.toml").read_text())
    with (source / "tests.csv").open() as old, (folder / "tests.csv").open("w") as new:
        rows = list(csv.DictReader(line for line in old if not line.startswith("#")))
        writer = csv.DictWriter(new, fieldnames=[*rows[0], "specimen"])
        writer.writeheader()
        writer.writerows({**row, "specimen": "S1"} for row in rows)


def test_tests_of_one_named_specimen_are_held_out_one_by_one(tmp_path: Path) -> None:
    write_hidden_effect_set(tmp_path / "plain", 13, None, repeats=Repeats(_CONDITIONS, 3, 0.2))
    _one_specimen(tmp_path / "plain", tmp_path / "named")
    plain, named = (load_measurement_set(tmp_path / n) for n in ("plain", "named"))
    assert {t.specimen_id for t in named.tests} == {"S1"}
    for a, b in zip(_baseline_fit(plain).heldout_force_n, _baseline_fit(named).heldout_force_n,
                    strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.slow
def test_diagnosis_names_the_spread_across_specimens(tmp_path: Path) -> None:
    data, _ = _named_set(tmp_path / "set", 14, 0.2)
    result = diagnose(data, DiagnosisParams(workers=2))
    assert result.causes == ("specimen_variability",)
    report = result.to_json()["specimen_variability"]
    assert sorted(report["by_specimen"]["specimens"]) == ["S1", "S2", "S3", "S4"]
    assert 0.75 <= result.intervals.overall_coverage <= 1.0
    from cell.diagnosis.specimen.report import write_report

    markdown = write_report(result, tmp_path / "report")[-1].read_text()
    assert "4 named specimens, each held out whole" in markdown


def test_the_bench_takes_named_specimens_with_spread_alone() -> None:
    from cell.cli import main

    assert main(["bench", "diagnose", "--by-specimen", "--seeds", "1"]) == 2
    assert main(["bench", "cell", "--spread", "--by-specimen"]) == 2


def test_the_named_specimens_bench_draws_spreads_of_5_to_25_percent() -> None:
    from cell.bench.spread import bench_seeds, spread_sd

    seeds = bench_seeds(50, by_specimen=True)
    cvs = [np.sqrt(np.expm1(spread_sd(s, by_specimen=True) ** 2)) for s in seeds]
    assert min(cvs) >= 0.05 and max(cvs) <= 0.25
    assert not set(seeds) & set(bench_seeds(50))
