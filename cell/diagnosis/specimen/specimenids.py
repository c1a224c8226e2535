"""``specimen_variability`` across named specimens: a set whose tests carry specimen ids
(the ``specimen`` column of ``tests.csv``) tells each specimen's modulus factor apart from
the model's error, whatever the specimens' protocols.

Per test, the log factor that fits its force best, ``u_k``, with its variance from the noise
``v_k`` (:func:`cell.diagnosis.specimen.spread.log_factors`), is read as a linear mixed
model with crossed terms: ``u_k = mu_c + b_s + e_k``. ``mu_c`` is a fixed mean per condition
(tests under equal conditions, :mod:`cell.diagnosis.specimen.repeats`: the model's own misfit
of that condition, the same for every specimen), ``b_s ~ N(0, sd**2)`` the specimen's log
modulus factor (the random effect), ``e_k ~ N(0, v_k + tau**2)`` what moves one test of a
specimen against its others beyond the noise (``tau``: a specimen is never exactly one
factor). ``sd`` and ``tau`` maximise the restricted (REML) likelihood; the cause is named on
the same rule as between repeats (:mod:`cell.diagnosis.specimen.spread`): the likelihood
ratio against ``sd = 0`` (``tau`` profiled) beyond the boundary mixture's critical value at
:data:`~cell.diagnosis.specimen.spread.LEVEL`, and ``sd`` at least
:data:`~cell.diagnosis.specimen.spread.MIN_SD`. The 95 % interval of ``sd`` is the profile
likelihood's; each specimen's factor is ``exp(b_s)`` at its best linear unbiased prediction,
with the 95 % interval of its prediction error.

The held-out scores of such a set leave whole specimens out (:func:`specimen_folds`,
:class:`~cell.diagnosis.specimen.fitting.Problem`): a test is predicted by the fit to the
other specimens, never by its own specimen's other tests.

Example:
    >>> u = np.array([0.1, 0.12, -0.1, -0.08, 0.0, 0.01])
    >>> fit = crossed_reml(u, np.full(6, 1e-6), [[0, 2, 4], [1, 3, 5]], [[0, 1], [2, 3], [4, 5]])
    >>> round(fit.sd, 2), fit.ratio > 10
    (0.1, True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize, minimize_scalar
from scipy.stats import chi2, norm

from cell.diagnosis.specimen.planeseries import PlaneSeries, Series
from cell.diagnosis.specimen.spread import (
    MIN_SD,
    SpecimenFactor,
    SpecimenSpread,
    critical_ratio,
    log_factors,
)

# Largest sd and tau searched.
_MAX_SD = 3.0
# Chi-square(1) quantile of the profile likelihood's 95 % interval.
_CI_LEVEL = 0.95
# Points of the profile likelihood's grid.
_GRID = 121
# A log-likelihood gain below this is none.
_FLAT = 1e-9


def _specimen_id(series: Series) -> str:
    """The specimen a fitted test names (a shear or biaxial one's own test's)."""
    return series.test.specimen_id if isinstance(series, PlaneSeries) else series.specimen_id


def specimen_folds(tests: tuple[Series, ...]) -> list[list[int]]:
    """The tests of each named specimen (indices, in the order their specimens first come),
    when every test names one, two or more are named and one of them has two or more tests;
    else none (one specimen throughout, or each test another: the repeats' path)."""
    ids = [_specimen_id(t) for t in tests]
    if not all(ids) or len(set(ids)) < 2 or len(set(ids)) == len(ids):
        return []
    order = list(dict.fromkeys(ids))
    return [[k for k, i in enumerate(ids) if i == name] for name in order]


@dataclass(frozen=True)
class CrossedFit:
    """The crossed mixed model's REML fit (module docstring).

    Attributes:
        sd: the specimens' sd of the log factor.
        tau: the tests' own sd within a specimen, beyond the noise.
        ratio: twice the restricted log-likelihood gain over ``sd = 0``.
        ci95: the profile interval of ``sd`` (its upper end NaN where the data do not
            bound it).
        blup: per specimen, its log factor's best linear unbiased prediction.
        blup_sd: per specimen, the standard deviation of its prediction error.

    Example:
        >>> CrossedFit(0.1, 0.0, 20.0, (0.05, 0.2), np.zeros(2), np.ones(2)).sd
        0.1
    """

    sd: float
    tau: float
    ratio: float
    ci95: tuple[float, float]
    blup: np.ndarray
    blup_sd: np.ndarray


class _Model:
    """The restricted likelihood of ``u`` (variances ``v``) with condition means ``x`` and
    specimen indicators ``z``."""

    def __init__(self, u: np.ndarray, v: np.ndarray, x: np.ndarray, z: np.ndarray) -> None:
        self.u, self.v, self.x, self.z = u, v, x, z

    def projection(self, sd: float, tau: float) -> tuple[np.ndarray, float]:
        """``P = V^-1 - V^-1 X (X^T V^-1 X)^-1 X^T V^-1`` and ``log|V| + log|X^T V^-1 X|``."""
        cov = sd**2 * self.z @ self.z.T + np.diag(self.v + tau**2)
        inverse = np.linalg.inv(cov)
        inner = self.x.T @ inverse @ self.x
        half = inverse @ self.x
        logdet = np.linalg.slogdet(cov)[1] + np.linalg.slogdet(inner)[1]
        return inverse - half @ np.linalg.solve(inner, half.T), float(logdet)

    def loss(self, sd: float, tau: float) -> float:
        """Minus the restricted log-likelihood."""
        p, logdet = self.projection(sd, tau)
        return 0.5 * (logdet + float(self.u @ p @ self.u))

    def profiled(self, sd: float) -> tuple[float, float]:
        """(loss, tau) at ``sd``, tau at its best."""
        best = minimize_scalar(lambda t: self.loss(sd, t), bounds=(0.0, _MAX_SD),
                               method="bounded", options={"xatol": 1e-6})
        at_zero = self.loss(sd, 0.0)
        return (float(best.fun), float(best.x)) if best.fun < at_zero else (at_zero, 0.0)


def crossed_reml(u: np.ndarray, v: np.ndarray, conditions: list[list[int]],
                 specimens: list[list[int]]) -> CrossedFit:
    """The REML fit of ``u`` (variances ``v``) about the means of ``conditions`` with one
    random factor per group of ``specimens`` (module docstring)."""
    x = np.zeros((len(u), len(conditions)))
    z = np.zeros((len(u), len(specimens)))
    for c, group in enumerate(conditions):
        x[group, c] = 1.0
    for s, group in enumerate(specimens):
        z[group, s] = 1.0
    model = _Model(u, v, x, z)
    null, _ = model.profiled(0.0)
    starts = [(0.05, 0.0), (0.2, 0.05), (float(np.std(u)) + 0.01, 0.01)]
    best = min((minimize(lambda p: model.loss(*p), start, method="L-BFGS-B",
                         bounds=[(0.0, _MAX_SD)] * 2) for start in starts),
               key=lambda r: r.fun)
    # A likelihood flat in sd (no condition repeated) leaves it at none.
    sd, tau = ((float(best.x[0]), float(best.x[1])) if best.fun < null - _FLAT
               else (0.0, model.profiled(0.0)[1]))
    peak = min(float(best.fun), null)
    ratio = max(2.0 * (null - peak), 0.0)
    grid = np.linspace(0.0, min(_MAX_SD, 3.0 * sd + 0.2), _GRID)
    limit = chi2.ppf(_CI_LEVEL, 1)
    inside = grid[[2.0 * (model.profiled(g)[0] - peak) <= limit for g in grid]]
    p, _ = model.projection(sd, tau)
    blup = sd**2 * z.T @ p @ u
    error = sd**2 - sd**4 * np.einsum("ks,kl,ls->s", z, p, z)
    # An interval that reaches the grid's end is not bounded by the data.
    high = float(inside.max()) if inside.max() < grid[-1] else math.nan
    return CrossedFit(sd, tau, ratio, (float(inside.min()), high), blup,
                      np.sqrt(np.maximum(error, 0.0)))


def spread_by_specimen(tests: tuple[Series, ...], fitted_n: tuple[np.ndarray, ...], offset_n: float,
                       noise_n: float, conditions: list[list[int]],
                       specimens: list[list[int]]) -> SpecimenSpread:
    """The specimen spread of ``tests`` about their fitted forces across the named
    ``specimens`` (:func:`specimen_folds`), ``conditions`` the tests under equal conditions
    (module docstring)."""
    u, v = log_factors(tests, fitted_n, offset_n, noise_n)
    crossed = crossed_reml(u, v, conditions, specimens)
    critical = critical_ratio()
    z95 = float(norm.ppf(0.975))
    names = [_specimen_id(tests[g[0]]) for g in specimens]
    factors = {name: SpecimenFactor(math.exp(b), math.exp(b - z95 * e), math.exp(b + z95 * e),
                                    tuple(tests[k].test_id for k in group))
               for name, b, e, group in zip(names, crossed.blup, crossed.blup_sd, specimens,
                                            strict=True)}
    return SpecimenSpread(crossed.ratio > critical and crossed.sd >= MIN_SD, crossed.sd,
                          crossed.ci95, crossed.ratio, critical, (),
                          {t.test_id: float(x) for t, x in zip(tests, u, strict=True)},
                          factors, crossed.tau)
