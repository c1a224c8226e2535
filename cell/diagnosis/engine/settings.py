"""The settings of a diagnosis (:class:`DiagnosisParams`): how many samples a fit uses, what a
cause must do to be named, and how many processes fit candidates side by side.

They sit below the diagnosis and the two modules it drives (:mod:`cell.diagnosis.engine.search`,
:mod:`cell.diagnosis.engine.acceptance`), so that each reads them without importing the module
on top.

Usage::

    diagnose(load_measurement_set("assets/measured/beef_round_example"),
             DiagnosisParams(workers=2))
"""

from __future__ import annotations

from dataclasses import dataclass, field

from cell.cores import default_workers
from cell.errors import DiagnosisError


@dataclass(frozen=True)
class DiagnosisParams:
    """How a set is diagnosed.

    Attributes:
        fit_samples: samples per test that fits use (all of them for held-out errors).
        min_variance_drop: a cause must lower the held-out mean square error by more than this
            many noise variances.
        max_rmse_ratio: and bring the held-out RMSE below this fraction of what it was (the
            springs cannot follow every law exactly, and a cause must explain more than the
            shape of a misfit the others leave).
        later_rmse_ratio: the same bound for a cause after the first, which has more misfit
            of the springs to absorb.
        min_improved_fraction: a cause after the first must also lower the held-out error of
            at least this fraction of the tests: a real effect shows in many tests, a cause
            that only absorbs in a few of them what the springs cannot follow is not one.
        unexplained_ratio: held-out RMSE over the noise above which left structure counts.
        structure_correlation: lag-one autocorrelation of held-out residuals above which
            they have structure.
        workers: processes fitting candidates side by side (default:
            :func:`~cell.cores.default_workers`).
        max_evaluations: cap on a fit's simulations of the set.

    Raises:
        DiagnosisError: ``fit_samples`` < 8 or ``workers`` < 1.

    Example:
        >>> DiagnosisParams(workers=2).fit_samples
        32
    """

    fit_samples: int = 32
    min_variance_drop: float = 1.0
    max_rmse_ratio: float = 0.85
    later_rmse_ratio: float = 0.75
    min_improved_fraction: float = 0.5
    unexplained_ratio: float = 2.0
    structure_correlation: float = 0.5
    workers: int = field(default_factory=default_workers)
    max_evaluations: int = 400

    def __post_init__(self) -> None:
        if self.fit_samples < 8:
            raise DiagnosisError(None, "fit_samples", f"must be >= 8, got {self.fit_samples}")
        if self.workers < 1:
            raise DiagnosisError(None, "workers", f"must be >= 1, got {self.workers}")
