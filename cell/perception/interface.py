"""The hidden interface as the camera's looks tell it: through the seen valley, leaning as the
opened cut shows.

Every look of the camera gives a guideline: the bottom of the valley between the muscles, on
the interface's top edge before the cut and deeper in the opening after each pass. At each x
the looks' (y, z) points lie on the interface, so the interface there is the prior surface
(the generic model's interface) shifted along y onto them. Before the cut only the top is
seen and the shift is the same all the way down, so the lean is the prior's; as the passes
open the cut, the looks span a height and the shift's slope over it takes over: a
least-squares slope ridged to zero with weight ``prior_rise_m`` squared, so that looks a few
millimetres apart, whose slope the noise would decide, move it little.

An affine fit of the generic model (:class:`~cell.perception.predicted.PredictedInterface`)
leans as its shears say, which a top view hardly constrains: on shapes drawn from the
documented ranges its planned tip can run a centimetre and more from the true interface,
this estimate's, with the prior lean alone, a few millimetres (``docs/benchmarks.md``).

Example (a prior leaning 0.1 through y = 0 at z = 0.66 m):
    >>> def prior(x_m, z_m):
    ...     return 0.1 * (np.asarray(z_m) - 0.66) + 0.0 * np.asarray(x_m)
    >>> top = np.array([[-0.2, 0.002, 0.66], [0.2, 0.002, 0.66]])  # seen 2 mm off the prior
    >>> estimate = SeenInterface((top,), prior)
    >>> round(float(estimate(np.array([0.0]), np.array([0.61]))[0]), 4)  # 5 cm down
    -0.003
    >>> deeper = top + [0.0, -0.006, -0.03]  # the opened cut shows it leaning 0.2
    >>> round(float(estimate.seen(deeper).lean(np.array([0.0]))[0]), 3)  # ridged to the prior
    0.182
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cell.config import require_positive
from cell.errors import PerceptionError

#: The rise between looks at which their slope weighs as much as the prior's lean, m.
PRIOR_RISE_M = 0.01
# Height step over which the estimate's lean is measured, m.
_LEAN_STEP_M = 0.01


@dataclass(frozen=True, eq=False)
class SeenInterface:
    """The interface as the surface y(x, z) (world frame, m) through the looks' guidelines:
    the callable :func:`controllers.knife.plan_cut` takes as ``interface_y``.

    At each x it is the prior surface shifted along y by what the looks saw there, the shift
    itself leaning as the looks' residuals do over their height span (ridged to no lean).
    Past a guideline's ends its nearest end's shift holds and the prior's shape goes on.

    Attributes:
        looks_m: each look's guideline (K, 3), m, in the order seen.
        prior: the interface y(x, z) where the looks do not tell (the generic model's own,
            :meth:`~cell.tissue.geometry.TwoMuscleMesh.interface_y`), m.
        prior_rise_m: the looks' height span at which their slope weighs as much as the
            prior's lean, m.

    The module's example shows one.
    """

    looks_m: tuple[np.ndarray, ...]
    prior: Callable[[np.ndarray, np.ndarray], np.ndarray]
    prior_rise_m: float = PRIOR_RISE_M

    def __post_init__(self) -> None:
        require_positive(self, "prior_rise_m")
        if not self.looks_m or any(len(look) < 2 for look in self.looks_m):
            raise PerceptionError("the interface needs a look with a guideline of two points")

    def seen(self, guideline_m: np.ndarray) -> SeenInterface:
        """This estimate with one more look's guideline (K, 3), m."""
        look = np.asarray(guideline_m, dtype=float).reshape(-1, 3)
        return SeenInterface((*self.looks_m, look), self.prior, self.prior_rise_m)

    def _residuals_at(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(L, ...) every look's height at ``x`` and its y less the prior's there, m."""
        residuals, heights = [], []
        for look in self.looks_m:
            order = np.argsort(look[:, 0])
            along, y, z = look[order].T
            residual = y - self.prior(along, z)
            residuals.append(np.interp(x, along, residual))
            heights.append(np.interp(x, along, z))
        return np.array(residuals), np.array(heights)

    def _shift(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The looks' mean residual, mean height and residual slope d(residual)/dz at x."""
        residual, z = self._residuals_at(x)
        dz, dr = z - z.mean(axis=0), residual - residual.mean(axis=0)
        slope = (dz * dr).sum(axis=0) / ((dz * dz).sum(axis=0) + self.prior_rise_m**2)
        return residual.mean(axis=0), z.mean(axis=0), slope

    def lean(self, x_m: np.ndarray) -> np.ndarray:
        """dy/dz of the estimate at ``x_m`` (world, m), at the looks' mean height."""
        x = np.asarray(x_m, dtype=float)
        _, z, slope = self._shift(x)
        return slope + (self.prior(x, z + _LEAN_STEP_M) - self.prior(x, z)) / _LEAN_STEP_M

    def __call__(self, x_m: np.ndarray, z_m: np.ndarray) -> np.ndarray:
        """World y (m) of the interface at world (x, z) (m); broadcasts."""
        x, z = np.broadcast_arrays(np.asarray(x_m, dtype=float), np.asarray(z_m, dtype=float))
        residual, height, slope = self._shift(x)
        return self.prior(x, z) + residual + slope * (z - height)

    def deepest_m(self) -> float:
        """How far the deepest look lies below the first at its lowest point, m: how much of
        the interface the opened cut has shown."""
        first = self.looks_m[0][np.argsort(self.looks_m[0][:, 0])]
        below = [float(np.max(np.interp(look[:, 0], first[:, 0], first[:, 2]) - look[:, 2]))
                 for look in self.looks_m[1:]]
        return max(below, default=0.0)
