"""The fits of one diagnosis, remembered by their causes (:class:`Search`), and what the
engine reads of a family of causes and of a fitted model (:class:`Family`, :class:`Fit`).

A family of causes (the specimen's, :mod:`cell.diagnosis.specimen.search`; the cut's,
:mod:`cell.diagnosis.cut.search`) subclasses :class:`Search` with its catalogue, its mutually
exclusive pair if it has one, the model variants of an added cause, its removal rule, the
starts of a fit and how one model is fitted from a start; the selection
(:mod:`cell.diagnosis.engine.selection`) walks any of them the same way.

Usage::

    search = SpecimenSearch(problem, params, root, pool)
    baseline = search.run([(None, None)])[0]
    candidates = search.run([(baseline, c) for c in search.catalogue])
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import replace
from typing import Any, ClassVar, Protocol

from cell.diagnosis.engine.acceptance import Rules
from cell.diagnosis.engine.fit import Fit, FitModel, Start, start_values
from cell.diagnosis.engine.settings import DiagnosisParams


def _task(args: tuple) -> Fit:
    """The best of ``models`` on held-out tests, each fitted from every one of ``starts`` and
    the fit with the lower residual kept."""
    fit_model, problem, models, starts, evaluations = args
    fits = [min((fit_model(problem, model, start_values(start, model), evaluations)
                 for start in starts), key=lambda f: f.rmse_n) for model in models]
    return min(fits, key=lambda f: f.heldout_rmse_n)


class Family(Protocol):
    """What a family of causes gives the selection: its catalogue, its mutually exclusive
    pair (the plainer cause first; empty when none), its acceptance rules, and per added or
    removed cause the models and starts to fit (:class:`Search` implements the rest)."""

    catalogue: tuple[str, ...]
    exclusive: tuple[str, ...]
    rules: Rules

    def variants(self, model: Any, cause: str) -> list[Any]: ...

    def removed(self, model: Any, cause: str) -> Any: ...

    def starts(self, base: Fit | None, cause: str | None) -> list[Start]: ...


class Search:
    """The fits of one diagnosis, remembered by their causes, run side by side in ``pool``
    (None: in this process); ``root`` is the model every candidate extends. A family
    subclasses it (:class:`Family`'s members and ``fit_model``).

    Example:
        >>> from cell.diagnosis.specimen.search import SpecimenSearch
        >>> SpecimenSearch.exclusive
        ('viscoelasticity', 'nonlinear_viscoelasticity')
    """

    #: The causes a step may add (a family may read it from its registry).
    catalogue: tuple[str, ...] = ()
    exclusive: ClassVar[tuple[str, ...]] = ()
    rules: ClassVar[Rules] = Rules()
    #: How one model is fitted from a start (:data:`FitModel`).
    fit_model: ClassVar[FitModel]

    def __init__(self, problem: Any, params: DiagnosisParams, root: Any,
                 pool: Executor | None = None) -> None:
        self.problem, self.params, self.root, self.pool = problem, params, root, pool
        self.fits: dict[frozenset[str], Fit] = {}
        #: Called with 1 after each fit (a progress bar's ``update``), or None.
        self.on_fit: Callable[[int], object] | None = None
        #: What the second look (:func:`~cell.diagnosis.engine.selection.forward`) tried.
        self.swaps: list[Any] = []

    def variants(self, model: Any, cause: str) -> list[Any]:
        """The models of ``model`` with ``cause`` added (the best on held-out tests kept)."""
        return [replace(model, causes=(*model.causes, cause))]

    def removed(self, model: Any, cause: str) -> Any:
        """``model`` without ``cause``."""
        return replace(model, causes=tuple(c for c in model.causes if c != cause))

    def starts(self, base: Fit | None, cause: str | None) -> list[Start]:
        """The starts of a model fitted from ``base`` with ``cause`` added or removed: the
        base's values (each start is fitted, the lower residual kept)."""
        return [None if base is None else (base.model.parameter_names, base.shape)]

    def run(self, jobs: list[tuple[Fit | None, str | None]]) -> list[Fit]:
        """Fit each (fit, cause): ``fit``'s model with ``cause`` added (None: the root
        model), started from ``fit``; or with its cause removed when the fit has it. A model
        fitted before is fitted again only when a cause is removed (the richer fit is a better
        start than the one it had), and the fit with the lower residual kept."""
        tasks, keys, refresh = [], [], set()
        fit_model = type(self).fit_model
        for base, cause in jobs:
            model = self.root if base is None else base.model
            if cause is None:
                models = [model]
            elif cause in model.causes:
                models = [self.removed(model, cause)]
                refresh.add(frozenset(models[0].causes))
            else:
                models = self.variants(model, cause)
            keys.append(frozenset(models[0].causes))
            tasks.append((fit_model, self.problem, models, self.starts(base, cause),
                          self.params.max_evaluations))
        todo = [(k, t) for k, t in zip(keys, tasks, strict=True)
                if k not in self.fits or k in refresh]
        unique = list({k: t for k, t in todo}.items())
        mapper: Callable = map if self.pool is None else self.pool.map
        for key, result in zip([k for k, _ in unique], mapper(_task, [t for _, t in unique]),
                               strict=True):
            if key not in self.fits or result.rmse_n < self.fits[key].rmse_n:
                self.fits[key] = result
            if self.on_fit is not None:
                self.on_fit(1)
        return [self.fits[k] for k in keys]
