"""Where a model is still wrong: the held-out residual's rank correlation with each quantity
the tests vary, its interval from resampling whole tests, the factor per test on the
prediction and what it follows, and a cut set whose force follows something no cause has,
pointed at by the diagnosis."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cell.diagnosis.cut.residuals import (
    MIN_TESTS,
    rank_trend,
    scales_between_tests,
    strongest,
)
from cell.diagnosis.cut.search import diagnose_cuts
from cell.outputs import first_non_finite
from tests.cutsets import sawing_set


def test_a_residual_that_grows_with_a_quantity_correlates_fully_and_clearly():
    values = [np.linspace(0.0, 1.0, 40) + k for k in range(5)]
    trend = rank_trend("depth_m", "against the cut", values, [3.0 * v for v in values])
    assert trend.rank_correlation == pytest.approx(1.0)
    assert trend.ci95[0] > 0.95
    assert strongest([trend]) is trend


def test_noise_gives_an_interval_around_zero_and_no_strongest_trend():
    rng = np.random.default_rng(3)
    values = [np.linspace(0.0, 1.0, 200) for _ in range(8)]
    trend = rank_trend("time_s", "along the edge", values,
                       [rng.normal(size=200) for _ in values])
    assert trend.ci95[0] < 0.0 < trend.ci95[1]
    assert strongest([trend]) is None


def test_a_quantity_that_does_not_vary_has_no_trend():
    flat = [np.zeros(20) for _ in range(4)]
    assert rank_trend("stroke_m", "along the edge", flat, [np.arange(20.0)] * 4) is None


def test_too_few_tests_give_the_correlation_and_an_undetermined_interval():
    values = [np.linspace(0.0, 1.0, 30) for _ in range(MIN_TESTS - 1)]
    trend = rank_trend("depth_m", "against the cut", values, values)
    assert trend.ci95 is None
    entry = trend.to_json()
    assert entry["ci95"] is None and "fewer than" in entry["ci95_reason"]


def test_forces_scaled_with_each_tests_speed_give_their_factors_and_follow_the_speed():
    block, blade, tests = sawing_set(stiffness_n_m=0.0)
    speeds = [float(np.median(np.abs(np.gradient(t.stroke_m(blade), t.time_s))))
              for t in tests]
    factors = [0.5 + 20.0 * speed for speed in speeds]
    predicted = [(t.force_n / f).T.ravel() for t, f in zip(tests, factors, strict=True)]
    scales = scales_between_tests(tests, block, blade, predicted)
    assert scales.scales == pytest.approx(factors)
    assert scales.share == pytest.approx(1.0)
    top = strongest(scales.trends)
    assert top.quantity == "median stroke_speed_m_s"
    assert top.rank_correlation == pytest.approx(1.0)


def test_a_prediction_right_in_every_test_has_factors_of_one_and_nothing_to_remove():
    block, blade, tests = sawing_set(stiffness_n_m=0.0)
    predicted = [t.force_n.T.ravel() for t in tests]
    scales = scales_between_tests(tests, block, blade, predicted)
    assert scales.scales == pytest.approx([1.0] * len(tests))
    assert scales.share == 0.0


def test_a_force_no_cause_has_is_left_unexplained_and_pointed_at():
    result = diagnose_cuts(*sawing_set(stiffness_n_m=300.0))
    assert result.causes[-1] == "unexplained"
    top = strongest(result.residual_trends)
    assert (top.quantity, top.component) == ("stroke_m", "along the edge")
    assert top.rank_correlation < -0.5
    payload = json.loads(json.dumps(result.to_json()))
    assert first_non_finite(payload) is None
    assert payload["residual_trends"][0]["quantity"] == "stroke_m"
    assert 0.0 <= payload["residual_test_scales"]["share"] <= 1.0
    assert len(payload["residual_test_scales"]["scales"]) == len(result.extended.heldout_force_n)


def test_a_set_the_causes_explain_has_no_trend_to_report():
    result = diagnose_cuts(*sawing_set(stiffness_n_m=0.0))
    assert "unexplained" not in result.causes
    assert result.residual_trends == ()
    assert result.to_json()["residual_trends"] == []
    assert result.to_json()["residual_test_scales"] is None
