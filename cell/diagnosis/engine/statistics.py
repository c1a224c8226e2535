"""The statistics every diagnosis scores its fits with: one information criterion, one normal
quantile, one rule for a parameter's 95 % interval.

Example:
    >>> round(bic(rss=2.0, count=100, parameters=3), 2)
    -377.39
"""

from __future__ import annotations

import math

import numpy as np

#: Two-sided 95 % quantile of the standard normal distribution.
Z95 = 1.959963984540054


def bic(rss: float, count: float, parameters: int) -> float:
    """Bayesian information criterion of a least-squares fit with a normal error: ``rss`` the
    residual sum of squares over ``count`` samples (independent ones: fewer than the samples where
    the residual is correlated), ``parameters`` fitted."""
    return count * math.log(max(rss / count, 1e-300)) + parameters * math.log(count)


#: A singular value of a Jacobian below this share of its largest is a direction the data do
#: not see: the share at which ``numpy.linalg.pinv`` drops it from ``J^T J`` (1e-15 there,
#: on the squares, the eigenvalues of ``J^T J``).
BLIND_SHARE = math.sqrt(1e-15)
#: A parameter with more than this weight along a blind direction is not determined.
BLIND_WEIGHT = 1e-6


def half_widths_95(jacobian: np.ndarray, variance: float) -> np.ndarray:
    """Half-widths of the 95 % intervals of the parameters of a least-squares fit from its
    Jacobian (columns: the parameters) and residual variance, ``Z95 sqrt(diag((J^T J)^-1) s^2)``;
    NaN for a parameter the data do not determine: one with weight along a direction the
    Jacobian does not see (alone, or traded against others), where a pseudo-inverse would
    give it a finite, falsely narrow interval.

    Example:
        >>> j = np.array([[1.0, 2.0, 0.0], [1.0, 2.0, 1.0], [1.0, 2.0, 2.0]])
        >>> np.isnan(half_widths_95(j, 0.01)).tolist()  # the first two trade off
        [True, True, False]
    """
    normal = jacobian.T @ jacobian
    strengths, directions = np.linalg.eigh(normal)
    blind = directions[:, strengths <= BLIND_SHARE**2 * max(strengths.max(initial=0.0), 0.0)]
    with np.errstate(divide="ignore", invalid="ignore"):
        half = Z95 * np.sqrt(np.diag(np.linalg.pinv(normal)) * variance)
    unseen = np.abs(blind).max(axis=1, initial=0.0) > BLIND_WEIGHT
    return np.where(np.isfinite(half) & ~unseen, half, np.nan)
