"""Held-out predictions with 90 % intervals: the parameters' covariance clustered by test, the
discrepancy each sample needs, the intervals of a fit and their coverage."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cell.diagnosis.specimen.causes import CandidateMaterial
from cell.diagnosis.specimen.diagnosis import noise_n
from cell.diagnosis.specimen.fitting import Problem, fit
from cell.diagnosis.specimen.intervals import (
    LEVEL,
    Z90,
    clustered_covariance,
    discrepancy_needed,
    prediction_intervals,
)
from cell.measure.specimens import load_measurement_set
from cell.synthetic.specimen import Repeats, write_hidden_effect_set


def test_clustered_covariance_of_a_mean_counts_tests_not_samples() -> None:
    # A mean fitted to 4 tests of 50 samples, each test off by its own amount: its variance
    # is that of 4 numbers, not of 200 independent samples.
    offsets = np.array([0.3, -0.1, -0.4, 0.2])
    gradients = [np.ones((50, 1)) for _ in offsets]
    residuals = [np.full(50, c) for c in offsets]
    covariance = clustered_covariance(gradients, residuals)
    assert covariance[0, 0] == pytest.approx(np.sum(offsets**2) / 16 * 4 / 3)


def test_a_sample_inside_the_base_interval_needs_no_discrepancy() -> None:
    needed = discrepancy_needed(np.array([0.1, 1.0, 1.0]), np.array([1.0, 2.0, 0.0]),
                                np.array([0.01, 0.01, 0.01]))
    assert needed[0] == 0.0
    assert needed[1] == pytest.approx((1.0 / Z90**2 - 0.01) / 4.0)
    assert needed[2] == np.inf


@pytest.mark.parametrize("spread_sd", [0.0, 0.2])
def test_intervals_cover_the_held_out_samples(tmp_path: Path, spread_sd: float) -> None:
    write_hidden_effect_set(tmp_path, 6, None, repeats=Repeats(5, 3, spread_sd))
    data = load_measurement_set(tmp_path)
    problem = Problem.of(data.specimen, data.tests, 32)
    fitted = fit(problem, CandidateMaterial(()), np.zeros(0), 10)
    intervals = prediction_intervals(problem, fitted, noise_n(data), spread_sd)
    assert LEVEL - 0.1 <= intervals.overall_coverage <= 1.0
    for low, center, high in zip(intervals.lower_n, intervals.center_n, intervals.upper_n,
                                 strict=True):
        assert np.all(low <= center) and np.all(center <= high)
    entry = intervals.to_json()
    assert entry["level"] == LEVEL and len(entry["tests"]) == 15
    assert (intervals.parts_n["specimen"] > 0.0) == (spread_sd > 0.0)
