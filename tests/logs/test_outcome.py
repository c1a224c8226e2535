"""The evidence of a log beyond its forces (:mod:`cell.logs.outcome`): the ``[outcome]``
counts and the release events in time, each in units of its own noise, and how much a count
far from the log's weighs in the diagnosis's comparison; the wide screening probes."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from cell.logs.causes import CAUSES
from cell.logs.fit import Rows, forward_selection, logged_vector, rmse_n
from cell.logs.outcome import (
    COUNTS,
    EVENT_CAP,
    EVENT_CHANNELS,
    EVIDENCE_ROWS,
    count_entries,
    count_misfits,
    event_misfit,
    event_misfits,
    evidence_weight,
)
from cell.logs.search import outcome_locators, screening_worlds
from cell.measure.logs import Channel
from tests.logcases import wave_log

LOGGED = {"bindings": 120, "released": 110, "torn": 73}


def test_a_replay_that_tears_5_where_the_log_tore_73_is_far_outside_the_counts_noise() -> None:
    far = count_misfits(LOGGED, {"bindings": 120, "released": 100, "torn": 5})
    near = count_misfits(LOGGED, {"bindings": 120, "released": 109, "torn": 72})
    torn = COUNTS.index("torn")
    assert far[torn] < -10.0
    assert np.all(np.abs(near) < 1.0)


def test_a_log_without_an_outcome_gives_no_count_evidence() -> None:
    assert not count_misfits({}, {"bindings": 120, "released": 100, "torn": 5}).any()


def _dropped(log_channels: dict[str, Channel], at_s: float) -> dict[str, Channel]:
    """``log_channels`` whose force falls to nothing at ``at_s`` (a release)."""
    return {name: replace(channel, force_n=np.where(channel.time_s[:, None] < at_s,
                                                    channel.force_n + 5.0, 0.0))
            for name, channel in log_channels.items()}


def test_a_release_a_step_late_is_within_timing_noise_and_one_much_later_costs_the_cap(
        ) -> None:
    unreleased = wave_log(101)  # a sample every 10 ms
    log = replace(unreleased, channels=_dropped(unreleased.channels, 0.5))
    step_late = event_misfits(log, _dropped(unreleased.channels, 0.51))
    much_later = event_misfits(log, _dropped(unreleased.channels, 0.9))
    never = event_misfits(log, {k: replace(c, force_n=np.ones_like(c.force_n))
                                for k, c in log.channels.items()})
    assert np.all(np.abs(step_late) < 0.5)
    assert np.allclose(much_later, EVENT_CAP) and np.allclose(never, EVENT_CAP)
    assert len(step_late) == len(EVENT_CHANNELS)


def _stepped(channel: Channel, levels: list[tuple[float, float]]) -> Channel:
    """``channel`` whose force magnitude is 10 N, then each level (N) from its time (s) on."""
    magnitude = np.full(channel.time_s.size, 10.0)
    for at_s, level in levels:
        magnitude[channel.time_s >= at_s] = level
    return replace(channel, force_n=np.outer(magnitude, [0.0, 0.0, 1.0]))


def test_two_drops_alike_match_whichever_side_found_the_other_one_largest() -> None:
    knife = wave_log(101).channels["knife"]  # a sample every 10 ms
    # The edge through one binding at 0.3 s and the next at 0.7 s, back to 10 N between:
    # the log's larger drop is the first, the replay's the second, by a few percent.
    logged = _stepped(knife, [(0.3, 4.5), (0.5, 10.0), (0.7, 4.8)])
    replayed = _stepped(knife, [(0.3, 5.0), (0.5, 10.0), (0.7, 4.4)])
    assert event_misfit(logged, replayed, 0.01) == 0.0
    # A release the replay has nowhere near the log's size still costs the cap.
    assert event_misfit(logged, _stepped(knife, [(0.3, 9.0)]), 0.01) == EVENT_CAP


def test_a_release_at_the_event_cut_off_in_one_run_only_is_matched_in_the_other() -> None:
    knife = wave_log(101).channels["knife"]
    logged = _stepped(knife, [(0.4, 7.4)])  # a drop of 26 % of the peak: an event
    replayed = _stepped(knife, [(0.41, 7.6)])  # 24 %: none of its own, one step late
    assert abs(event_misfit(logged, replayed, 0.01)) < 0.5


def test_a_count_misfit_is_what_the_selection_sees_when_the_forces_agree() -> None:
    logs = [wave_log(200), wave_log(200)]
    measured, rows = logged_vector(logs, EVIDENCE_ROWS)
    assert isinstance(rows, Rows) and (~rows.force).sum() == 2 * EVIDENCE_ROWS
    rng = np.random.default_rng(0)
    weight = evidence_weight(rmse_n(np.full(3, 0.1)), 10)  # a force sample forgets in 10
    torn = COUNTS.index("torn")
    # The replays' forces agree with the logs to their noise; their torn counts do not.
    simulated = measured + rng.normal(0.0, 0.1, measured.size) * rows.force
    off = count_misfits(LOGGED, {"bindings": 120, "released": 100, "torn": 5})
    evidence = np.flatnonzero(~rows.force).reshape(len(logs), EVIDENCE_ROWS)
    for entries in evidence:
        simulated[entries[:len(COUNTS)]] = weight * off
    residual = measured - simulated
    force_only = rmse_n(residual[rows.force])
    assert rmse_n(residual) > 1.1 * force_only
    # A cause that tears more, and changes the forces by no more than their noise.
    tears = np.zeros((measured.size, 1))
    tears[evidence[:, torn], 0] = weight * off[torn]
    tears[rows.force, 0] = rng.normal(0.0, 0.01, rows.force.sum())
    steps = forward_selection(residual, {"tearing_threshold": tears}, rows, 0.08)
    assert [step.added for step in steps[1:]] == ["tearing_threshold"]


def test_the_wide_probes_reach_a_threshold_halved_and_a_stiffness_two_and_a_half_times() -> None:
    for name in ("tearing_threshold", "tissue_stiffness"):
        factors = [math.exp(m) for m in CAUSES[name].probes(wide=True)]
        assert min(factors) == pytest.approx(0.41, abs=0.02)
        assert max(factors) == pytest.approx(2.46, abs=0.02)
    assert CAUSES["tissue_stiffness"].probes(wide=False) == (0.3, -0.3)
    worlds = screening_worlds(["tearing_threshold", "tissue_stiffness"], {}, wide=True)
    assert len(worlds) == 8


def test_the_outcome_locates_a_cause_between_its_probes_where_the_counts_agree() -> None:
    # Two logs, each a force sample and its evidence: the counts' misfits run linear in the
    # magnitude, zero at -0.6 (a threshold lowered to 0.55 times); the forces say nothing.
    evidence = np.tile(np.r_[False, np.ones(EVIDENCE_ROWS, bool)], 2)
    counts = count_entries(evidence)
    assert counts.sum() == 2 * len(COUNTS) and not counts[~evidence].any()

    def replayed(magnitude: float) -> np.ndarray:
        vector = np.zeros(evidence.size)
        vector[counts] = np.tile([0.0, 2.0 * (magnitude + 0.6)], 2)
        return vector

    probes = CAUSES["tearing_threshold"].probes(True)
    located = outcome_locators(replayed(0.0), ["tearing_threshold"],
                               [replayed(p) for p in probes], counts)
    assert located["tearing_threshold"] == pytest.approx(-0.6)
    # Counts already the log's in the lab's world: no locator, whatever the probes give.
    agreeing = outcome_locators(np.zeros(evidence.size), ["tearing_threshold"],
                                [replayed(p) for p in probes], counts)
    assert agreeing == {}
