"""The log diagnosis compares forces averaged over COMPARED_WINDOW_S: a sharp event a control
step late costs little there, while what changes over seconds passes unchanged."""

from __future__ import annotations

import numpy as np

from cell.logs.fit import COMPARED_WINDOW_S, averaged

STEP_S = 0.02  # the cell's control step, at which its logs are sampled
TIME_S = np.arange(0.0, 4.0, STEP_S)


def _spike(at_s: float) -> np.ndarray:
    force = np.zeros((TIME_S.size, 3))
    force[np.argmin(abs(TIME_S - at_s)), 0] = 30.0
    return force


def _rms(residual: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(residual ** 2, axis=1))))


def test_a_spike_one_step_late_costs_a_fraction_of_its_raw_misfit() -> None:
    logged, replayed = _spike(2.0), _spike(2.0 + STEP_S)
    raw = _rms(logged - replayed)
    compared = _rms(averaged(TIME_S, logged) - averaged(TIME_S, replayed))
    assert compared < 0.3 * raw


def test_a_slow_change_passes_the_average_unchanged() -> None:
    ramp = np.column_stack([5.0 * TIME_S, np.full(TIME_S.size, 2.0), -TIME_S])
    margin = int(np.ceil(COMPARED_WINDOW_S / STEP_S))  # the ends average fewer samples
    inside = slice(margin, -margin)
    assert np.allclose(averaged(TIME_S, ramp)[inside], ramp[inside])


def test_the_average_never_crosses_a_tare() -> None:
    force = np.where(TIME_S[:, None] < 1.0, 8.0, 0.0) * np.ones((1, 3))
    assert np.allclose(averaged(TIME_S, force, split_s=1.0), force)
    assert not np.allclose(averaged(TIME_S, force), force)


def test_irregular_samples_are_averaged_by_time() -> None:
    time_s = np.array([0.0, 0.01, 0.5, 0.51, 1.0])
    force = np.array([[1.0], [3.0], [10.0], [20.0], [7.0]])
    assert averaged(time_s, force)[:, 0].tolist() == [2.0, 2.0, 15.0, 15.0, 7.0]
