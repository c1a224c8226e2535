"""What the engine reads of a family's candidate model and of its fit (typed, where a fit was
once a plain dict), and the start of a fit from a related one.

Usage::

    start_values((fit.model.parameter_names, fit.shape), richer_model)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

#: The (names, values) of a related fit that a start is read from; None: the model's initial
#: values.
Start = tuple[tuple[str, ...], np.ndarray] | None


class Candidate(Protocol):
    """A candidate model of a family (a dataclass): its causes, its shape parameters' names
    and initial values."""

    @property
    def causes(self) -> tuple[str, ...]: ...

    @property
    def parameter_names(self) -> tuple[str, ...]: ...

    @property
    def initial(self) -> np.ndarray: ...


class Fit(Protocol):
    """What the engine reads of a fitted model: its candidate, fitted shape parameters, RMSE
    on the fitted samples and held out (N), BIC and held-out forces per test."""

    @property
    def model(self) -> Any: ...

    @property
    def shape(self) -> np.ndarray: ...

    @property
    def rmse_n(self) -> float: ...

    @property
    def heldout_rmse_n(self) -> float: ...

    @property
    def bic(self) -> float: ...

    @property
    def heldout_force_n(self) -> tuple[np.ndarray, ...]: ...

    def heldout_mse_per_test(self, tests: tuple[Any, ...]) -> np.ndarray: ...


#: How one model of a family is fitted: (problem, model, start values, evaluations) -> fit.
#: A module-level function, so that a process pool can send it to its workers.
FitModel = Callable[[Any, Any, np.ndarray, int], Any]


def start_values(previous: Start, model: Candidate) -> np.ndarray:
    """A start for ``model`` from the (names, values) of a related fit: its values where the
    names match, ``model.initial`` elsewhere (everywhere when None)."""
    start = model.initial.copy()
    if previous is not None:
        names, values = previous
        for i, name in enumerate(model.parameter_names):
            if name in names:
                start[i] = values[names.index(name)]
    return start


