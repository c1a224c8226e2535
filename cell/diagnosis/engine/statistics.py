"""The statistics every diagnosis scores its fits with: one information criterion, one normal
quantile.

Example:
    >>> round(bic(rss=2.0, count=100, parameters=3), 2)
    -377.39
"""

from __future__ import annotations

import math

#: Two-sided 95 % quantile of the standard normal distribution.
Z95 = 1.959963984540054


def bic(rss: float, count: float, parameters: int) -> float:
    """Bayesian information criterion of a least-squares fit with a normal error: ``rss`` the
    residual sum of squares over ``count`` samples (independent ones: fewer than the samples where
    the residual is correlated), ``parameters`` fitted."""
    return count * math.log(max(rss / count, 1e-300)) + parameters * math.log(count)
