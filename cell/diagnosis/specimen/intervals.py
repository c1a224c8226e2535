"""Predictions with intervals: each held-out test's prediction (the fit without that test) with
a 90 % interval per sample, and how many of the held-out samples the intervals cover.

The variance of a held-out sample is the sum of four parts:

- the noise: the set's force noise, squared;
- the specimen: another cube of the muscle is another specimen, its material ``exp(u)``
  times the population's, ``u ~ N(0, sd**2)`` (:mod:`cell.diagnosis.specimen.spread`, when named):
  ``sd**2`` times the predicted material force squared;
- the parameters: ``g C g^T``, with ``g`` the prediction's sensitivity to the shape
  parameters, the log modulus and the offset (finite differences at the fit) and ``C`` their
  covariance clustered by test (the sandwich ``A^-1 B A^-1``, ``A = G^T G``,
  ``B = sum_k G_k^T r_k r_k^T G_k``): a test is one specimen, its residuals move together;
- the model's own discrepancy: ``delta**2`` times the predicted material force squared, what
  the held-out residuals show the model cannot remove. ``delta`` for test k is the least that
  makes the intervals of the *other* tests cover :data:`LEVEL` of their held-out samples (a
  leave-one-test-out calibration: the test never sets its own interval).

The interval is the prediction plus or minus :data:`Z90` standard deviations.

Example:
    >>> needed = discrepancy_needed(np.array([0.3, 0.0]), np.array([1.0, 1.0]),
    ...                             np.array([0.01, 0.01]))
    >>> needed.round(4).tolist()
    [0.0233, 0.0]
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from cell.diagnosis.engine.determined import NOT_PREDICTED, determined, determined_each
from cell.diagnosis.specimen.fitting import REFERENCE_PA, ModelFit, Problem

#: Share of held-out samples an interval is to cover.
LEVEL = 0.9
#: Two-sided 90 % quantile of the normal distribution.
Z90 = 1.644854
# Step of the finite differences, as a share of a shape parameter's bounds.
_STEP_SHARE = 1e-3


@dataclass(frozen=True, eq=False)
class PredictionIntervals:
    """The held-out predictions of a fit with their intervals (module docstring).

    Attributes:
        test_ids: the tests, in the set's order.
        center_n: per test, the held-out prediction at every sample, N.
        lower_n, upper_n: per test, the interval's bounds, N.
        coverage: per test, the share of its samples inside its interval.
        discrepancy: per test, the relative discrepancy ``delta`` its interval carries.
        parts_n: RMS over every sample of each part's standard deviation (``noise``,
            ``specimen``, ``parameters``, ``discrepancy``), N.

    Example:
        >>> one = PredictionIntervals(("t00",), (np.zeros(2),), (np.full(2, -1.0),),
        ...                           (np.ones(2),), (0.5,), (0.0,), {})
        >>> one.overall_coverage
        0.5
    """

    test_ids: tuple[str, ...]
    center_n: tuple[np.ndarray, ...]
    lower_n: tuple[np.ndarray, ...]
    upper_n: tuple[np.ndarray, ...]
    coverage: tuple[float, ...]
    discrepancy: tuple[float, ...]
    parts_n: dict[str, float]

    @property
    def overall_coverage(self) -> float:
        """The share of every held-out sample of the set inside its interval."""
        sizes = np.array([len(c) for c in self.center_n])
        return float(np.array(self.coverage) @ sizes / sizes.sum())

    def to_json(self) -> dict[str, Any]:
        """The JSON's ``intervals`` entry (a number the fit does not determine ``null``,
        with its reason: :mod:`cell.diagnosis.engine.determined`)."""
        return {"level": LEVEL, "coverage": self.overall_coverage,
                "parts_rms_N": determined_each(self.parts_n, NOT_PREDICTED),
                "tests": [{"test_id": t, "coverage": c,
                           **determined("discrepancy", d, NOT_PREDICTED),
                           **determined("prediction_N", p, NOT_PREDICTED),
                           **determined("lower_N", lo, NOT_PREDICTED),
                           **determined("upper_N", hi, NOT_PREDICTED)}
                          for t, c, d, p, lo, hi in zip(
                              self.test_ids, self.coverage, self.discrepancy, self.center_n,
                              self.lower_n, self.upper_n, strict=True)]}


def sensitivities(problem: Problem, fitted: ModelFit) -> list[np.ndarray] | None:
    """Per test, (samples, parameters) derivatives of its force at every sample: the shape
    parameters, the log modulus, then the offset when fitted; None when the model cannot run."""
    model, shape = fitted.model, fitted.shape
    scale = fitted.modulus_pa / REFERENCE_PA
    base = problem.unit_forces(model, shape, problem.tests)
    if base is None:
        return None
    lower, upper = model.bounds
    columns: list[list[np.ndarray]] = []
    for i in range(len(shape)):
        step = _STEP_SHARE * float(upper[i] - lower[i])
        if shape[i] + step > upper[i]:
            step = -step
        moved = shape.copy()
        moved[i] += step
        units = problem.unit_forces(model, moved, problem.tests)
        columns.append([np.zeros_like(b) if units is None else scale * (u - b) / step
                        for u, b in zip(units or base, base, strict=True)])
    columns.append([scale * b for b in base])
    if model.has_offset:
        columns.append([np.ones_like(b) for b in base])
    return [np.stack([c[k] for c in columns], axis=1) for k in range(len(base))]


def clustered_covariance(gradients: list[np.ndarray], residuals: list[np.ndarray]
                         ) -> np.ndarray:
    """The parameters' covariance clustered by test (module docstring)."""
    norm = np.sqrt(sum((g**2).sum(axis=0) for g in gradients))
    # A parameter no prediction moves has no variance to give: its column stays zero.
    norm = np.where(norm > 0.0, norm, 1.0)
    scaled = [g / norm for g in gradients]
    inverse = np.linalg.pinv(sum(g.T @ g for g in scaled), rcond=1e-10)
    scores = [g.T @ r for g, r in zip(scaled, residuals, strict=True)]
    clusters = len(gradients)
    meat = sum(np.outer(s, s) for s in scores) * clusters / max(clusters - 1, 1)
    return inverse @ meat @ inverse / np.outer(norm, norm)


def discrepancy_needed(residual: np.ndarray, material: np.ndarray,
                       base_variance: np.ndarray) -> np.ndarray:
    """Per sample, the least ``delta**2`` whose interval covers it (inf when no ``delta``
    does: no material force there)."""
    excess = residual**2 / Z90**2 - base_variance
    with np.errstate(divide="ignore", invalid="ignore"):
        needed = np.where(excess <= 0.0, 0.0, excess / material**2)
    return np.where(np.isfinite(needed), needed, math.inf)


def prediction_intervals(problem: Problem, fitted: ModelFit, noise_n: float,
                         spread_sd: float) -> PredictionIntervals:
    """The held-out predictions of ``fitted`` with their intervals (module docstring);
    ``spread_sd`` is the specimen spread (0 when none is named)."""
    tests = problem.tests
    residual_fit = [t.force_n - f for t, f in zip(tests, fitted.fitted_force_n, strict=True)]
    gradients = sensitivities(problem, fitted)
    centers = fitted.heldout_force_n
    material = [c - fitted.offset_n for c in centers]
    if gradients is None:
        parameters = [np.zeros_like(c) for c in centers]
    else:
        covariance = clustered_covariance(gradients, residual_fit)
        parameters = [np.maximum(((g @ covariance) * g).sum(axis=1), 0.0) for g in gradients]
    specimen = [(spread_sd * m) ** 2 for m in material]
    base = [noise_n**2 + s + p for s, p in zip(specimen, parameters, strict=True)]
    needed = [discrepancy_needed(t.force_n - c, m, b)
              for t, c, m, b in zip(tests, centers, material, base, strict=True)]
    owner = np.concatenate([np.full(len(n), k) for k, n in enumerate(needed)])
    pooled = np.concatenate(needed)
    deltas, lower, upper, coverage = [], [], [], []
    for k, test in enumerate(tests):
        others = pooled[owner != k]
        delta2 = float(np.quantile(others, LEVEL, method="inverted_cdf")) if len(others) else 0.0
        delta2 = delta2 if math.isfinite(delta2) else float(np.max(others[np.isfinite(others)],
                                                                   initial=0.0))
        half = Z90 * np.sqrt(base[k] + delta2 * material[k] ** 2)
        lower.append(centers[k] - half)
        upper.append(centers[k] + half)
        coverage.append(float(np.mean(np.abs(test.force_n - centers[k]) <= half)))
        deltas.append(math.sqrt(delta2))
    parts = {"noise": noise_n, "specimen": _rms(specimen), "parameters": _rms(parameters),
             "discrepancy": _rms([(d * m) ** 2 for d, m in zip(deltas, material, strict=True)])}
    return PredictionIntervals(tuple(t.test_id for t in tests), tuple(centers), tuple(lower),
                               tuple(upper), tuple(coverage), tuple(deltas), parts)


def _rms(variances: list[np.ndarray]) -> float:
    """RMS standard deviation over every sample of per-sample ``variances``."""
    return float(math.sqrt(np.mean(np.concatenate(variances))))
