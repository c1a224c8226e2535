"""Where a model is still wrong: the held-out residual against each quantity its tests vary,
as a rank correlation with a 95 % interval, so that a set left ``unexplained`` points at what
the model is missing (a force that grows with depth, one that follows the stroke's speed).

The samples of one test follow each other and are not independent, so the interval comes
from resampling whole tests (a cluster bootstrap), never from the count of samples.

A model can also be wrong between tests rather than within them: the right shape, scaled
differently from one test to the next (a force that grows with the speed each test was run
at, say). :func:`scales_between_tests` fits one factor per test to its held-out prediction,
gives the share of the residual those factors remove, and correlates the factors with each
test's median of each quantity.

Example:
    >>> t = [np.linspace(0.0, 1.0, 50) + k for k in range(4)]
    >>> trend = rank_trend("time_s", "against the cut", t, [x**2 for x in t])
    >>> round(trend.rank_correlation, 3), trend.ci95[0] > 0.9
    (1.0, True)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from cell.diagnosis.cut.reduced import cutting_direction
from cell.measure.cuts import Blade, Block, CutTest

#: Resamples of the tests behind an interval.
RESAMPLES = 1000
#: Samples of a test that a resample keeps at the most (evenly spread): enough for a rank
#: correlation, few enough that the bootstrap stays well under a second.
RESAMPLE_POINTS = 200
#: Fewer tests than this give no interval (resampling two tests says little).
MIN_TESTS = 3


@dataclass(frozen=True)
class ResidualTrend:
    """How the held-out residual (measured less predicted) follows one quantity.

    Attributes:
        quantity: what the tests vary, with its unit (``depth_m``, ``stroke_speed_m_s``).
        component: which force's residual (``against the cut``, ``along the edge``).
        rank_correlation: Spearman's rank correlation over every sample, in [-1, 1].
        ci95: its 95 % interval from resampling whole tests, or None with fewer than
            :data:`MIN_TESTS` tests.
    """

    quantity: str
    component: str
    rank_correlation: float
    ci95: tuple[float, float] | None

    def to_json(self) -> dict[str, Any]:
        """The JSON's ``residual_trends`` entry (``ci95`` null with its reason)."""
        entry: dict[str, Any] = {"quantity": self.quantity, "component": self.component,
                                 "rank_correlation": self.rank_correlation,
                                 "ci95": None if self.ci95 is None else list(self.ci95)}
        if self.ci95 is None:
            entry["ci95_reason"] = f"fewer than {MIN_TESTS} tests to resample"
        return entry


def _spearman(x: np.ndarray, y: np.ndarray) -> float:
    rank_x, rank_y = (np.argsort(np.argsort(v, kind="stable")).astype(float) for v in (x, y))
    rank_x -= rank_x.mean()
    rank_y -= rank_y.mean()
    return float(rank_x @ rank_y / np.sqrt((rank_x @ rank_x) * (rank_y @ rank_y)))


def rank_trend(quantity: str, component: str, values: Sequence[np.ndarray],
               residuals: Sequence[np.ndarray], seed: int = 0) -> ResidualTrend | None:
    """The trend of ``residuals`` in ``values`` (one array of each per test), or None when
    the quantity does not vary or the residual is flat (no rank to correlate)."""
    pooled_x, pooled_y = np.concatenate(values), np.concatenate(residuals)
    if np.ptp(pooled_x) == 0.0 or np.ptp(pooled_y) == 0.0:
        return None
    rho = _spearman(pooled_x, pooled_y)
    if len(values) < MIN_TESTS:
        return ResidualTrend(quantity, component, rho, None)
    thinned = [np.linspace(0, len(x) - 1, min(len(x), RESAMPLE_POINTS)).astype(int)
               for x in values]
    rng = np.random.default_rng(seed)
    draws = []
    for _ in range(RESAMPLES):
        picked = rng.integers(len(values), size=len(values))
        x = np.concatenate([values[i][thinned[i]] for i in picked])
        y = np.concatenate([residuals[i][thinned[i]] for i in picked])
        if np.ptp(x) > 0.0 and np.ptp(y) > 0.0:
            draws.append(_spearman(x, y))
    if len(draws) < RESAMPLES // 2:
        return ResidualTrend(quantity, component, rho, None)
    low, high = np.percentile(draws, [2.5, 97.5])
    return ResidualTrend(quantity, component, rho, (float(low), float(high)))


def strongest(trends: Sequence[ResidualTrend]) -> ResidualTrend | None:
    """The trend the residual follows most: the largest rank correlation whose interval
    excludes zero (None when none does)."""
    clear = [t for t in trends if t.ci95 is not None and (t.ci95[0] > 0.0 or t.ci95[1] < 0.0)]
    return max(clear, key=lambda t: abs(t.rank_correlation), default=None)


def cut_quantities(test: CutTest, block: Block, blade: Blade) -> dict[str, np.ndarray]:
    """What a cut test varies, per sample: the edge's depth below the top face, its stroke
    along itself, the stroke's speed (its magnitude, m/s) and the time."""
    stroke = test.stroke_m(blade)
    return {"depth_m": test.depth_m(block), "stroke_m": stroke,
            "stroke_speed_m_s": np.abs(np.gradient(stroke, test.time_s)),
            "time_s": test.time_s - test.time_s[0]}


@dataclass(frozen=True)
class ScalesBetweenTests:
    """How much of the held-out residual is one factor per test on the prediction, and what
    the factors follow.

    Attributes:
        scales: per test, the factor (dimensionless) that best scales its held-out prediction
            to its measured force (least squares; 1 where the prediction is zero).
        share: the share of the residual's sum of squares the factors remove, in [0, 1].
        trends: the factors' rank correlation with each test's median of each quantity of
            :func:`cut_quantities` over its samples in the block (quantity ``median
            depth_m`` ...), the strongest first.

    Example:
        >>> ScalesBetweenTests((1.0, 2.0), 0.5, ()).to_json()["share"]
        0.5
    """

    scales: tuple[float, ...]
    share: float
    trends: tuple[ResidualTrend, ...]

    def to_json(self) -> dict[str, Any]:
        """The JSON's ``residual_test_scales``."""
        return {"scales": list(self.scales), "share": self.share,
                "trends": [t.to_json() for t in self.trends]}


def scales_between_tests(tests: Sequence[CutTest], block: Block, blade: Blade,
                         heldout_force_n: Sequence[np.ndarray]) -> ScalesBetweenTests:
    """The factor per test on its held-out prediction (:class:`ScalesBetweenTests`);
    ``heldout_force_n`` as for :func:`cut_residual_trends`."""
    predicted = [np.asarray(pred).reshape(3, -1).T for pred in heldout_force_n]
    scales, before, after = [], 0.0, 0.0
    for test, pred in zip(tests, predicted, strict=True):
        size = float(np.sum(pred * pred))
        scale = float(np.sum(pred * test.force_n)) / size if size > 0.0 else 1.0
        scales.append(scale)
        before += float(np.sum((test.force_n - pred) ** 2))
        after += float(np.sum((test.force_n - scale * pred) ** 2))
    medians: dict[str, list[np.ndarray]] = {}
    for test in tests:
        inside = test.depth_m(block) > 0.0
        for name, values in cut_quantities(test, block, blade).items():
            middle = np.median(values[inside]) if inside.any() else np.median(values)
            medians.setdefault(f"median {name}", []).append(np.array([middle]))
    trends = [rank_trend(name, "per-test scale", values, [np.array([s]) for s in scales])
              for name, values in medians.items()]
    return ScalesBetweenTests(tuple(scales), 1.0 - after / before if before > 0.0 else 0.0,
                              _by_strength(trends))


def cut_residual_trends(tests: Sequence[CutTest], block: Block, blade: Blade,
                        heldout_force_n: Sequence[np.ndarray]) -> tuple[ResidualTrend, ...]:
    """The trends of the held-out residual of the force against the cut and along the edge
    in each quantity of :func:`cut_quantities`, the strongest first.

    ``heldout_force_n``: per test, the held-out prediction channel after channel (a cut
    fit's ``heldout_force_n``)."""
    directions = {"against the cut": -cutting_direction(blade),
                  "along the edge": np.asarray(blade.edge_direction)}
    quantities = [cut_quantities(test, block, blade) for test in tests]
    residuals = {name: [(test.force_n - np.asarray(pred).reshape(3, -1).T) @ direction
                        for test, pred in zip(tests, heldout_force_n, strict=True)]
                 for name, direction in directions.items()}
    trends = [rank_trend(quantity, component, [q[quantity] for q in quantities], series)
              for quantity in quantities[0] for component, series in residuals.items()]
    return _by_strength(trends)


def _by_strength(trends: Sequence[ResidualTrend | None]) -> tuple[ResidualTrend, ...]:
    """The trends there are, the largest rank correlation (either sign) first."""
    return tuple(sorted((t for t in trends if t is not None),
                        key=lambda t: -abs(t.rank_correlation)))
