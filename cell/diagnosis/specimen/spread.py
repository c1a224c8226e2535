"""``specimen_variability``: each test is another specimen, and specimens differ. A random
effect on the fitted material: test k's specimen has the material times ``exp(u_k)`` (every
modulus: the simulated force is linear in them), ``u_k ~ N(0, sd**2)``, the population values
being the fit's own.

The spread is read where it cannot be anything else: between tests under equal conditions
(:mod:`cell.diagnosis.specimen.repeats`). Per test, the log factor that fits its force best,
``u_k = log(1 + m.r / m.m)`` (``m`` the fitted material force, ``r`` the residual), with its
variance from the noise ``v_k = s_k**2 / (exp(u_k)**2 m.m)`` (``s_k`` the residual's RMS
after the factor, at least the set's noise). Within a group of repeats the model's own
misfit is the same for each test and drops out with the group's mean ``mu_g``:
``u_k ~ N(mu_g, sd**2 + v_k)``. The sd maximises the restricted (REML) likelihood of the
groups of two or more tests, the means profiled out; the 95 % interval is the profile
likelihood's. The cause is named when the likelihood ratio against ``sd = 0`` exceeds the
critical value of the boundary's half-and-half mixture of chi-square(0) and chi-square(1) at
level :data:`LEVEL`, and the sd is at least :data:`MIN_SD` (a spread below it changes no
prediction a lab acts on); never without repeats.

Example:
    >>> u = np.array([0.1, -0.1, 0.25, 0.0, -0.2, 0.05])
    >>> round(reml_sd(u, np.full(6, 1e-6), [[0, 1, 2], [3, 4, 5]])[0], 2)  # sqrt(SS / (6 - 2))
    0.16
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.stats import chi2

from cell.diagnosis.engine.determined import NOT_IDENTIFIABLE, determined, determined_each
from cell.measure.specimens import MechanicalTest

#: Level of the test against no spread.
LEVEL = 1e-3
#: Smallest spread named (standard deviation of the log factor).
MIN_SD = 0.02
# Largest spread searched.
_MAX_SD = 3.0
# Chi-square(1) quantile of the profile likelihood's 95 % interval.
_CI_LEVEL = 0.95


@dataclass(frozen=True)
class SpecimenFactor:
    """One named specimen's modulus factor on the population's material
    (:mod:`cell.diagnosis.specimen.specimenids`).

    Attributes:
        factor: ``exp(b)``, ``b`` its log factor's best linear unbiased prediction.
        ci95: the 95 % interval of the factor.
        tests: the specimen's test ids.

    Example:
        >>> SpecimenFactor(1.1, 0.9, 1.3, ("t00-1",)).to_json()["factor"]
        1.1
    """

    factor: float
    low: float
    high: float
    tests: tuple[str, ...]

    def to_json(self) -> dict[str, Any]:
        """The factor, its interval and tests."""
        return {"factor": self.factor, "ci95": [self.low, self.high], "tests": list(self.tests)}


@dataclass(frozen=True)
class SpecimenSpread:
    """The specimen spread of a set (module docstring).

    Attributes:
        named: whether ``specimen_variability`` is named.
        sd: fitted standard deviation of the log modulus factor (0 without repeats).
        ci95: its 95 % profile-likelihood interval (NaN without repeats or where the
            repeats do not bound it: ``null`` in JSON, with ``ci95_reason``).
        likelihood_ratio: twice the log-likelihood gain over no spread.
        critical: the ratio that names it.
        groups: test ids of each group of repeats (two or more tests).
        log_factors: per test id, the log factor its own force asks of the fit.
        specimens: per named specimen, its modulus factor (empty unless the tests name
            their specimens: :mod:`cell.diagnosis.specimen.specimenids`).
        within_sd: with named specimens, the tests' own sd of the log factor within a
            specimen beyond the noise.

    Example:
        >>> SpecimenSpread.absent().named
        False
    """

    named: bool
    sd: float
    ci95: tuple[float, float]
    likelihood_ratio: float
    critical: float
    groups: tuple[tuple[str, ...], ...]
    log_factors: dict[str, float]
    specimens: dict[str, SpecimenFactor] = field(default_factory=dict)
    within_sd: float = 0.0

    @property
    def cv(self) -> float:
        """The spread as the coefficient of variation of the modulus factor (lognormal)."""
        return _cv(self.sd)

    @classmethod
    def absent(cls) -> SpecimenSpread:
        """No spread measured (no repeats)."""
        return cls(False, 0.0, (math.nan, math.nan), 0.0, critical_ratio(), (), {})

    def to_json(self) -> dict[str, Any]:
        """The JSON's ``specimen_variability`` entry."""
        unbounded = (NOT_IDENTIFIABLE if self.groups or self.specimens
                     else "no tests repeat a condition")
        return {"named": self.named, **determined("log_modulus_sd", self.sd),
                **determined("ci95", list(self.ci95), unbounded),
                **determined("likelihood_ratio", self.likelihood_ratio),
                "critical": self.critical,
                "repeat_groups": [list(g) for g in self.groups],
                "log_modulus_factors": determined_each(self.log_factors),
                **({"by_specimen": self._by_specimen_json()} if self.specimens else {})}

    def _by_specimen_json(self) -> dict[str, Any]:
        """The spread across named specimens: the coefficient of variation with its
        interval, the tests' own sd within a specimen, each specimen's factor."""
        return {**determined("modulus_cv", self.cv),
                **determined("modulus_cv_ci95", [_cv(x) for x in self.ci95]),
                **determined("within_specimen_log_sd", self.within_sd),
                "held_out": "leave-one-specimen-out",
                "specimens": {name: f.to_json() for name, f in self.specimens.items()}}


def _cv(sd: float) -> float:
    """The coefficient of variation of ``exp(u)``, ``u ~ N(0, sd**2)``."""
    return math.sqrt(math.expm1(sd**2)) if math.isfinite(sd) else math.nan


def critical_ratio() -> float:
    """The likelihood ratio whose chance under no spread is ``LEVEL`` (the boundary's mixture:
    half of the time the ratio is 0)."""
    return float(chi2.isf(2.0 * LEVEL, 1))


def log_factors(tests: tuple[MechanicalTest, ...], fitted_n: tuple[np.ndarray, ...],
                offset_n: float, noise_n: float) -> tuple[np.ndarray, np.ndarray]:
    """Per test, the log factor on the fitted material force that fits it best, and its
    variance from the noise (module docstring)."""
    factors, variances = [], []
    for test, fitted in zip(tests, fitted_n, strict=True):
        material = fitted - offset_n
        energy = max(float(material @ material), 1e-300)
        ratio = max(1.0 + float(material @ (test.force_n - fitted)) / energy, 1e-3)
        left = test.force_n - offset_n - ratio * material
        scatter = max(float(np.mean(left**2)), noise_n**2, 1e-300)
        factors.append(math.log(ratio))
        variances.append(scatter / (ratio**2 * energy))
    return np.array(factors), np.array(variances)


def _restricted_loglik(sd: float, u: np.ndarray, v: np.ndarray,
                       groups: list[list[int]]) -> float:
    total = 0.0
    for group in groups:
        w = 1.0 / (sd**2 + v[group])
        mean = float(w @ u[group]) / float(w.sum())
        total -= 0.5 * (float(np.log(1.0 / w).sum()) + math.log(float(w.sum()))
                        + float(w @ (u[group] - mean) ** 2))
    return total


def reml_sd(u: np.ndarray, v: np.ndarray, groups: list[list[int]]
            ) -> tuple[float, float, tuple[float, float]]:
    """The REML sd of ``u`` (variances ``v``) about each group's mean, its likelihood ratio
    against 0 and its 95 % profile interval."""
    def loss(sd: float) -> float:
        return -_restricted_loglik(sd, u, v, groups)

    best = minimize_scalar(loss, bounds=(0.0, _MAX_SD), method="bounded",
                           options={"xatol": 1e-5})
    sd = float(best.x) if best.fun < loss(0.0) else 0.0
    peak = -loss(sd)
    ratio = max(2.0 * (peak + loss(0.0)), 0.0)
    grid = np.linspace(0.0, min(_MAX_SD, 3.0 * sd + 0.2), 601)
    limit = chi2.ppf(_CI_LEVEL, 1)
    inside = grid[[2.0 * (peak + loss(g)) <= limit for g in grid]]
    return sd, ratio, (float(inside.min()), float(inside.max()))


def specimen_spread(tests: tuple[MechanicalTest, ...], fitted_n: tuple[np.ndarray, ...],
                    offset_n: float, noise_n: float, groups: list[list[int]]) -> SpecimenSpread:
    """The specimen spread of ``tests`` about their fitted forces (module docstring);
    ``groups`` are the tests under equal conditions (:func:`repeat_groups`)."""
    u, v = log_factors(tests, fitted_n, offset_n, noise_n)
    repeated = [g for g in groups if len(g) >= 2]
    factors = {t.test_id: float(x) for t, x in zip(tests, u, strict=True)}
    if not repeated:
        return replace(SpecimenSpread.absent(), log_factors=factors)
    sd, ratio, ci95 = reml_sd(u, v, repeated)
    critical = critical_ratio()
    return SpecimenSpread(ratio > critical and sd >= MIN_SD, sd, ci95, ratio, critical,
                          tuple(tuple(tests[i].test_id for i in g) for g in repeated), factors)

