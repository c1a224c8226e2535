"""What every diagnosis reports the same way: the evidence for a named cause, the outcome of a
search (baseline, candidates, steps, extended model, gain) as the contract's JSON, and the
force noise estimated from the data.

Example:
    >>> import numpy as np
    >>> force = np.random.default_rng(0).normal(0.0, 0.01, 2000)
    >>> round(force_noise_n([np.cumsum(np.full(2000, 0.001)) + force]), 3)
    0.01
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cell.diagnosis.engine.determined import (
    NOT_PREDICTED,
    determined,
    determined_each,
    estimates_json,
)


@dataclass(frozen=True)
class Evidence:
    """Why one named cause is named.

    Attributes:
        cause: the cause.
        heldout_rmse_with_n: held-out RMSE of the final model, N.
        heldout_rmse_without_n: of the final model refitted without the cause, N (for
            ``nonlinear_viscoelasticity``: with ``viscoelasticity`` in its place).
        improved_fraction: fraction of the tests whose held-out error the cause lowers.
        params: the cause's shape parameters: value and 95 % interval (NaN where the data
            do not bound it: ``null`` in the JSON, with ``ci95_reason``), in the units of
            their names (``log_`` ones: natural log, except ``log_relaxation_time``: log10 s).
        without: the fit without the cause (for plots).
        with_fit: the fit with it, where that is not the extended model (for plots: for
            ``specimen_variability``, each test at its specimen's factor within its group of
            repeats).
        per_mode: in a set of several kinds of test (uniaxial, shear, biaxial), each mode's
            held-out RMSE with and without the cause, N; empty otherwise.
    """

    cause: str
    heldout_rmse_with_n: float
    heldout_rmse_without_n: float
    improved_fraction: float
    params: dict[str, tuple[float, float, float]]
    without: Any
    with_fit: Any = None
    per_mode: dict[str, tuple[float, float]] = field(default_factory=dict)

    @property
    def revealed_by(self) -> str | None:
        """The mode whose held-out error the cause lowers most (ratio without / with), None
        without ``per_mode``."""
        if not self.per_mode:
            return None
        return max(self.per_mode, key=lambda m: self.per_mode[m][1] / max(self.per_mode[m][0],
                                                                          1e-300))

    def to_json(self) -> dict[str, Any]:
        """The evidence as the JSON's ``evidence`` entry."""
        return {"cause": self.cause,
                **determined("heldout_rmse_with_N", self.heldout_rmse_with_n, NOT_PREDICTED),
                **determined("heldout_rmse_without_N", self.heldout_rmse_without_n,
                             NOT_PREDICTED),
                "improved_fraction": self.improved_fraction,
                "params": estimates_json(self.params),
                **({"per_mode": {mode: {"heldout_rmse_with_N": w, "heldout_rmse_without_N": wo}
                                 for mode, (w, wo) in self.per_mode.items()},
                    "revealed_by": self.revealed_by} if self.per_mode else {})}


class SearchOutcome:
    """What the uniaxial and the cut diagnosis share, from the fields of the dataclass that
    takes it in: ``noise_n``, ``baseline``, ``candidates``, ``steps``, ``extended`` and
    ``causes``."""

    @property
    def gain(self) -> float:
        """1 - extended over baseline held-out RMSE."""
        return 1.0 - self.extended.heldout_rmse_n / self.baseline.heldout_rmse_n

    def to_json(self) -> dict[str, Any]:
        """The diagnosis contract (docs/measured-data.md), plus the noise, the
        information criteria and the search's steps."""
        return {
            "baseline": self.baseline.to_json(),
            "causes": list(self.causes),
            "candidates": [
                {"cause": fit.model.causes[0], "params": determined_each(fit.params),
                 **fit.scores_json(),
                 "selected": fit.model.causes[0] in self.causes}
                for fit in self.candidates
            ],
            "extended": self.extended.to_json(),
            **determined("gain", self.gain, NOT_PREDICTED),
            "noise_N": self.noise_n,
            "steps": [{"causes": list(fit.model.causes), **fit.scores_json()}
                      for fit in self.steps],
            "second_look": [swap.to_json() for swap in self.swaps],
        }


def force_noise_n(forces: Iterable[np.ndarray]) -> float:
    """Force noise of force series, N: per series the robust spread of its second differences
    (1.4826 times their median absolute deviation, over sqrt(6): a smooth force cancels, white
    noise stays), the median over the series."""
    spreads = []
    for force in forces:
        second = np.diff(force, 2)
        if len(second) >= 3:
            spreads.append(1.4826 * np.median(np.abs(second - np.median(second))) / math.sqrt(6))
    return float(np.median(spreads)) if spreads else 0.0
