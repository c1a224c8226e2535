"""Whether a cause earns its place in a model of a measurement set, from the held-out errors
of the model with and without it (:func:`accepts`; the selection that asks is
:mod:`cell.diagnosis.engine.selection`), under the rules of the cause's family (:class:`Rules`).

Usage::

    accepts(richer, poorer, first=False, noise=noise_n(data), tests=data.tests,
            params=DiagnosisParams(), rules=SpecimenSearch.rules)  # richer: poorer plus one
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from cell.diagnosis.engine.fit import Fit
from cell.diagnosis.engine.outcome import force_noise_n
from cell.diagnosis.engine.settings import DiagnosisParams

#: The tests a fit is judged on: per test, its measured ``force_n`` and ``rest_samples``
#: (:class:`~cell.measure.specimens.MechanicalTest`,
#: :class:`~cell.diagnosis.cut.fitting.CutSeries`).
Tests = tuple[Any, ...]
#: Fewer samples at rest than this in a whole set: an offset is judged on the whole tests.
MIN_REST_SAMPLES = 3


def improved_fraction(fit: Fit, previous: Fit,
                      tests: Tests) -> float:
    """Fraction of the tests whose held-out RMSE ``fit`` lowers below ``previous``'s."""
    return float(np.mean(fit.heldout_mse_per_test(tests)
                         < previous.heldout_mse_per_test(tests)))


def structure(fit: Fit, tests: Tests) -> float:
    """Lag-one autocorrelation of the held-out residuals, pooled over tests."""
    products, squares = 0.0, 0.0
    for predicted, test in zip(fit.heldout_force_n, tests, strict=True):
        residual = predicted - test.force_n
        residual = residual - residual.mean()
        products += float(residual[1:] @ residual[:-1])
        squares += float(residual @ residual)
    return products / max(squares, 1e-300)


def every_test(richer: Fit, poorer: Fit, tests: Tests) -> list[int]:
    """Every test of the set: where a family judges each cause on the whole set."""
    return list(range(len(tests)))


@dataclass(frozen=True)
class Rules:
    """What a family of causes tells the acceptance: its causes that are a sensor's offset,
    judged at rest (:func:`_at_rest`), and which tests a richer model is judged on against a
    poorer one, (richer, poorer, tests) -> indices.

    Example:
        >>> Rules(offsets=("blade_force_offset",)).judged is every_test
        True
    """

    offsets: tuple[str, ...] = ()
    judged: Callable[[Fit, Fit, Tests], list[int]] = every_test


def _heldout_rmse_n(fit: Fit, tests: Tests,
                    judged: list[int]) -> float:
    """Held-out RMSE of ``fit`` over every sample of the ``judged`` tests, N."""
    errors = np.concatenate([fit.heldout_force_n[i] - tests[i].force_n for i in judged])
    return float(np.sqrt(np.mean(errors**2)))


def _at_rest(richer: Fit, poorer: Fit, tests: Tests,
             offsets: tuple[str, ...]) -> list[np.ndarray] | None:
    """Per test, the samples at rest (``rest_samples``: a specimen at the machine's zero, a
    blade in the air) when all that ``richer`` adds is a sensor's offset and the set has at
    least :data:`MIN_REST_SAMPLES` of them; None otherwise. There every model predicts no
    force, so the offset shows alone: over the whole tests, a material model that misses the
    tissue (a plastic set unlike the springs') leaves an error beside which the offset may
    look small, and the offset would be left unnamed however plain it is at rest."""
    added = set(richer.model.causes) - set(poorer.model.causes)
    if not added or not added <= set(offsets):
        return None
    rest = [test.rest_samples for test in tests]
    return rest if sum(len(r) for r in rest) >= MIN_REST_SAMPLES else None


def _scores_at_rest(richer: Fit, poorer: Fit, tests: Tests,
                    rest: list[np.ndarray]) -> tuple[float, float, float]:
    """Held-out RMSE of ``richer`` and ``poorer`` on the samples at rest (:func:`_at_rest`),
    N, and the share of tests at rest whose error ``richer`` lowers."""
    judged = [i for i, samples in enumerate(rest) if len(samples)]

    def errors(fit: Fit) -> list[np.ndarray]:
        return [fit.heldout_force_n[i][rest[i]] - tests[i].force_n[rest[i]] for i in judged]

    rich_errors, poor_errors = errors(richer), errors(poorer)
    rich, poor = (float(np.sqrt(np.mean(np.concatenate(e) ** 2)))
                  for e in (rich_errors, poor_errors))
    improved = float(np.mean([np.mean(r**2) < np.mean(p**2)
                              for r, p in zip(rich_errors, poor_errors, strict=True)]))
    return rich, poor, improved


def accepts(richer: Fit, poorer: Fit, *, first: bool, noise: float, tests: Tests,
            params: DiagnosisParams, rules: Rules) -> bool:
    """Whether ``richer`` (``poorer`` plus one cause) earns its cause (module docstring, 2;
    ``first``: the first cause of a model), on the tests ``rules.judged`` picks; a sensor's
    offset on the samples at rest (:func:`_at_rest`)."""
    rest = _at_rest(richer, poorer, tests, rules.offsets)
    if rest is not None:
        rich, poor, improved = _scores_at_rest(richer, poorer, tests, rest)
    else:
        judged = rules.judged(richer, poorer, tests)
        rich, poor = (_heldout_rmse_n(f, tests, judged) for f in (richer, poorer))
        if len(judged) < len(tests):
            # The variance a cause must remove is the noise of the samples it is judged on.
            noise = force_noise_n(tests[i].force_n for i in judged)
        improved = np.mean(richer.heldout_mse_per_test(tests)[judged]
                           < poorer.heldout_mse_per_test(tests)[judged])
    ratio = params.max_rmse_ratio if first else params.later_rmse_ratio
    return (poor**2 - rich**2 > params.min_variance_drop * noise**2 and richer.bic < poorer.bic
            and rich <= ratio * poor
            and (first or improved >= params.min_improved_fraction))
