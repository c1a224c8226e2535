"""Modulus curves: the tangent modulus of a spring against its stretch r (current over rest
length), the paper's 5th-degree polynomial or an exponential law, clamped outside its range.
The materials (:mod:`cell.tissue.material`) hold one per direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.polynomial import polynomial as P

from cell.errors import MaterialError

_DEGREE = 5
# The positivity check evaluates the modulus here and at its critical points in the range.
_POSITIVITY_SAMPLES = 2049
DEFAULT_R_MIN = 0.5
"""Lowest stretch of a curve's range unless given."""
DEFAULT_R_MAX = 1.5
"""Highest stretch of a curve's range unless given."""


@dataclass(frozen=True)
class ModulusCurve:
    """Tangent modulus as a function of the stretch r: the paper's 5th-degree polynomial or an
    exponential law, clamped outside its range.

    The modulus is ``E(r) = sum_k coefficients[k] * (r - 1)**k`` Pa inside ``[r_min, r_max]`` and
    its value at the nearer bound outside; with an ``exponent`` b > 0 it is the exponential law
    ``E(r) = coefficients[0] * exp(b |r - 1|)`` (collagen recruitment, stiffening both ways),
    whose other coefficients must be 0. The nominal stress is its integral from the rest
    state, ``sigma(r) = int_1^r E`` Pa, so the curve of a measured stress-stretch test is
    recovered by :meth:`fit` and reproduced by :meth:`stress_pa`.

    Attributes:
        coefficients: six polynomial coefficients in Pa; ``coefficients[0]`` is the small-strain
            modulus.
        r_min: lowest stretch of the fitted range, in (0, 1].
        r_max: highest stretch of the fitted range, >= 1.
        exponent: b of the exponential law (dimensionless); 0 for the polynomial.

    Raises:
        MaterialError: ``coefficients`` (not six finite numbers, or the modulus is not > 0
            everywhere in the range, or higher coefficients with an exponent), ``r_min`` or
            ``r_max`` (range not around 1), ``exponent`` (negative or not finite).

    Example:
        >>> curve = ModulusCurve((3e4, 1e5, 0, 0, 0, 0), r_min=0.8, r_max=1.3)
        >>> round(float(curve.modulus_pa(1.1)), 6), float(curve.modulus_pa(2.0))
        (40000.0, 60000.0)
        >>> round(float(curve.stress_pa(1.1)), 6)
        3500.0
        >>> round(float(ModulusCurve.exponential(3e4, 10.0).modulus_pa(0.9)), 1)
        81548.5
    """

    coefficients: tuple[float, float, float, float, float, float]
    r_min: float = DEFAULT_R_MIN
    r_max: float = DEFAULT_R_MAX
    exponent: float = 0.0

    def __post_init__(self) -> None:
        coefficients = np.asarray(self.coefficients, dtype=float)
        if coefficients.shape != (_DEGREE + 1,) or not np.isfinite(coefficients).all():
            raise MaterialError(
                None, "coefficients", f"must be six finite numbers, got {self.coefficients!r}"
            )
        object.__setattr__(self, "coefficients", tuple(coefficients.tolist()))
        if not (0.0 < self.r_min <= 1.0):
            raise MaterialError(None, "r_min", f"must be in (0, 1], got {self.r_min}")
        if not (1.0 <= self.r_max < math.inf and self.r_max > self.r_min):
            raise MaterialError(None, "r_max", f"must be >= 1 and > r_min, got {self.r_max}")
        if not (0.0 <= self.exponent < math.inf):
            raise MaterialError(None, "exponent", f"must be finite and >= 0, got {self.exponent}")
        if self.exponent and any(coefficients[1:]):
            raise MaterialError(None, "coefficients",
                                "an exponential curve takes coefficients[0] only, the rest 0")
        # A constant or exponential modulus is lowest at r = 1: positive where E(1) is (the
        # search over the range is most of the cost of a curve, and a fit makes thousands).
        if self.coefficients[0] > 0.0 and not any(self.coefficients[1:]):
            return
        lowest, where = _lowest(self)
        if not lowest > 0.0:
            raise MaterialError(
                None,
                "coefficients",
                f"modulus must be > 0 over [{self.r_min}, {self.r_max}], "
                f"got {lowest:.4g} Pa at r = {where:.4g}",
            )

    def _candidates(self, samples: int) -> np.ndarray:
        """``samples`` points spanning the range and the modulus's critical points in it, in
        x = r - 1: the modulus's extremes over the range are among them."""
        lo, hi = self.r_min - 1.0, self.r_max - 1.0
        critical = P.polyroots(P.polyder(self.coefficients)) if any(self.coefficients[1:]) else []
        # The real part of a nearly real pair (a nearly double root) still finds the extreme.
        return np.concatenate([np.linspace(lo, hi, samples), np.clip(np.real(critical), lo, hi)])

    def _minimum(self) -> tuple[float, float]:
        """Lowest modulus in the range (Pa) and the stretch where it is."""
        x = self._candidates(_POSITIVITY_SAMPLES)
        values = self._modulus_inside(x)
        i = int(np.argmin(values))
        return float(values[i]), float(x[i] + 1.0)

    @classmethod
    def constant(
        cls, modulus_pa: float, r_min: float = DEFAULT_R_MIN, r_max: float = DEFAULT_R_MAX
    ) -> ModulusCurve:
        """A linear material: the same modulus (Pa) at every stretch.

        Example:
            >>> ModulusCurve.constant(3e4).coefficients
            (30000.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        """
        return cls((modulus_pa, 0.0, 0.0, 0.0, 0.0, 0.0), r_min, r_max)

    @classmethod
    def exponential(
        cls, modulus_pa: float, exponent: float, r_min: float = DEFAULT_R_MIN,
        r_max: float = DEFAULT_R_MAX,
    ) -> ModulusCurve:
        """The exponential law ``modulus_pa * exp(exponent * |r - 1|)`` (Pa).

        Example:
            >>> ModulusCurve.exponential(3e4, 8.0).exponent
            8.0
        """
        return cls((modulus_pa, 0.0, 0.0, 0.0, 0.0, 0.0), r_min, r_max, exponent)

    @classmethod
    def fit(cls, stretch: np.ndarray, stress_pa: np.ndarray) -> ModulusCurve:
        """Least-squares fit to a measured nominal stress-stretch curve.

        The stress is fitted as the integral of the modulus polynomial, which makes it zero at
        r = 1 (the model is unloaded at rest) and avoids differentiating noisy data. The range
        is the measured one, widened to contain r = 1.

        Args:
            stretch: (n,) stretches (current over initial length), n >= 6, at least six distinct.
            stress_pa: (n,) nominal stresses (force over initial area), Pa.

        Raises:
            MaterialError: ``stretch`` or ``stress_pa`` unusable, or ``coefficients`` when the
                fitted modulus is not positive over the range.

        Example:
            >>> r = np.linspace(0.8, 1.3, 30)
            >>> curve = ModulusCurve.fit(r, 3e4 * (r - 1) + 5e4 * (r - 1) ** 2)
            >>> [round(c) for c in curve.coefficients[:3]]
            [30000, 100000, 0]
        """
        r = np.asarray(stretch, dtype=float).ravel()
        sigma = np.asarray(stress_pa, dtype=float).ravel()
        if r.shape != sigma.shape:
            raise MaterialError(
                None, "stress_pa", f"has {sigma.size} values for {r.size} stretches"
            )
        if not (np.isfinite(r).all() and (r > 0).all()):
            raise MaterialError(None, "stretch", "must be finite and > 0")
        if not np.isfinite(sigma).all():
            raise MaterialError(None, "stress_pa", "must be finite")
        if np.unique(r).size < _DEGREE + 1:
            raise MaterialError(
                None, "stretch", f"needs at least {_DEGREE + 1} distinct values, got {r.size}"
            )
        x = r - 1.0
        # Scaling x to [-1, 1] keeps the Vandermonde columns of similar size.
        scale = float(np.abs(x).max())
        k = np.arange(_DEGREE + 1)
        design = P.polyvander(x / scale, _DEGREE + 1)[:, 1:] / (k + 1)
        scaled, *_ = np.linalg.lstsq(design, sigma / scale, rcond=None)
        coefficients = scaled / scale**k
        return cls(tuple(coefficients.tolist()), min(float(r.min()), 1.0), max(float(r.max()), 1.0))

    @property
    def small_strain_modulus_pa(self) -> float:
        """Modulus at rest, Pa."""
        return self.coefficients[0]

    def _modulus_inside(self, x: np.ndarray) -> np.ndarray:
        """The modulus law at x = r - 1, unclamped, Pa."""
        if self.exponent:
            return self.coefficients[0] * np.exp(self.exponent * np.abs(x))
        return P.polyval(x, self.coefficients)

    def modulus_pa(self, r: np.ndarray | float) -> np.ndarray:
        """Tangent modulus d sigma / d r at stretch ``r``, Pa (clamped outside the range)."""
        return self._modulus_inside(np.clip(np.asarray(r, dtype=float), self.r_min, self.r_max)
                                    - 1.0)

    def stress_pa(self, r: np.ndarray | float) -> np.ndarray:
        """Nominal stress at stretch ``r``, Pa: the modulus integrated from r = 1."""
        r = np.asarray(r, dtype=float)
        x = np.clip(r, self.r_min, self.r_max) - 1.0
        if self.exponent:
            inside = np.sign(x) * self.coefficients[0] * np.expm1(self.exponent * np.abs(x)) / (
                self.exponent)
        else:
            inside = P.polyval(x, self.stress_coefficients())
        return inside + self.modulus_pa(r) * (r - 1.0 - x)

    def stress_coefficients(self) -> np.ndarray:
        """(7,) polynomial coefficients of the stress in (r - 1) inside the range, Pa (the
        polynomial law's; an exponential curve has none)."""
        return np.concatenate([[0.0], np.asarray(self.coefficients) / np.arange(1, _DEGREE + 2)])

    def max_modulus_pa(self) -> float:
        """Largest modulus at any stretch, Pa (it is reached inside the range)."""
        return float(self._modulus_inside(self._candidates(2)).max())


@lru_cache(maxsize=4096)
def _lowest(curve: ModulusCurve) -> tuple[float, float]:
    """``curve``'s lowest modulus in its range and where it is, remembered by its fields: a fit
    makes the same curves again at every step that leaves them."""
    return curve._minimum()
