"""The stepwise search of a diagnosis (:mod:`cell.diagnosis.specimen.diagnosis`, its module
docstring, 2 to 4): the fits of candidate materials side by side, the forward steps with their
look-ahead and backward drops, and the second start from the runner-up cause.

Usage::

    search = Search(problem, params, root, pool)
    baseline = search.run([(None, None)])[0]
    candidates = search.run([(baseline, c) for c in CAUSES])
    final, steps, order = forward(search, baseline, candidates, noise)
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from cell.diagnosis.engine.acceptance import accepts, structure
from cell.diagnosis.engine.determined import NOT_PREDICTED, determined
from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.specimen.causes import CAUSES, EXCLUSIVE, RELAXING, CandidateMaterial
from cell.diagnosis.specimen.fitting import ModelFit, Problem, fit
from cell.measure.specimens import MechanicalTest

# Single additions whose pairs the search tries when none passes alone.
_LOOK_AHEAD = 3
# Causes that the other causes' parameters absorb in part while they are missing: added to a
# model, they are also fitted from the model's own start.
_ABSORBED = (*RELAXING, "force_offset")


def _task(args: tuple) -> ModelFit:
    """The best of ``models`` on held-out tests, each fitted from every one of ``starts`` and
    the fit with the lower residual kept."""
    problem, models, starts, evaluations = args
    fits = [min((fit(problem, model, _start(start, model), evaluations) for start in starts),
                key=lambda f: f.rmse_n) for model in models]
    return min(fits, key=lambda f: f.heldout_rmse_n)


def _start(previous: tuple[tuple[str, ...], np.ndarray] | None,
           model: CandidateMaterial) -> np.ndarray:
    """A start for ``model`` from the (names, values) of a related fit: its values where the
    names match, ``model.initial`` elsewhere (everywhere when None)."""
    start = model.initial.copy()
    if previous is not None:
        names, values = previous
        for i, name in enumerate(model.parameter_names):
            if name in names:
                start[i] = values[names.index(name)]
    return start


def _variants(model: CandidateMaterial, cause: str) -> list[CandidateMaterial]:
    """``model`` with ``cause`` added (a viscoelasticity replacing the other), with both
    stiffening laws when the cause is stiffening. Anisotropy always has its oblique factor (the
    richer form holds the plainer one, and a form chosen early would be kept through later
    steps that it no longer suits), apart in compression as its El/Et is (tissue's shear term
    differs there: with one factor the tests at mid angles alone outweigh an asymmetry of
    every other test, and a plasticity stands in for it); the asymmetry is one factor on El
    and Et in compression (El and Et apart would also absorb the lattice's own difference
    between its anisotropy in tension and in compression, and name an asymmetry in every
    anisotropic set)."""
    causes = tuple(c for c in model.causes if not (c in EXCLUSIVE and cause in EXCLUSIVE))
    base = replace(model, causes=(*causes, cause))
    if cause == "strain_stiffening":
        return [replace(base, stiffening=law) for law in ("exponential", "polynomial")]
    return [base]


def _mirrored(fitted: ModelFit) -> tuple[tuple[str, ...], np.ndarray]:
    """``fitted``'s (names, values) with each compression term (``*_compressed``,
    ``compression_*``) at the value of its tension twin."""
    names, values = fitted.model.parameter_names, fitted.shape.copy()
    for i, name in enumerate(names):
        twin = name.removesuffix("_compressed").removeprefix("compression_")
        if twin != name and twin in names:
            values[i] = values[names.index(twin)]
    return names, values


class Search:
    """The fits of one diagnosis, remembered by their causes, run side by side in ``pool``
    (None: in this process); ``root`` is the material every candidate extends (the module
    docstring shows its use)."""

    def __init__(self, problem: Problem, params: DiagnosisParams, root: CandidateMaterial,
                 pool: Executor | None) -> None:
        self.problem, self.params, self.root, self.pool = problem, params, root, pool
        self.fits: dict[frozenset[str], ModelFit] = {}
        #: The causes a step may add: the cut tests' search (:mod:`cell.diagnosis.cut.search`)
        #: walks the same steps over its own catalogue.
        self.catalogue: tuple[str, ...] = CAUSES
        #: Called with 1 after each fit (a progress bar's ``update``), or None.
        self.on_fit: Callable[[int], object] | None = None
        #: What the second look (:func:`forward`) tried, in order.
        self.swaps: list[Swap] = []

    def run(self, jobs: list[tuple[ModelFit | None, str | None]]) -> list[ModelFit]:
        """Fit each (fit, cause): ``fit``'s model with ``cause`` added (None: the root
        model), started from ``fit``; or with its cause removed when the fit has it. A model
        fitted before is fitted again only when a cause is removed (the richer fit is a better
        start than the one it had), and the fit with the lower residual kept."""
        tasks, keys, refresh = [], [], set()
        for base, cause in jobs:
            model = self.root if base is None else base.model
            if cause is None:
                models = [model]
            elif cause in model.causes:
                kept = tuple(c for c in model.causes if c != cause)
                if cause == EXCLUSIVE[1]:
                    kept += (EXCLUSIVE[0],)
                models = [replace(model, causes=kept)]
                refresh.add(frozenset(kept))
            else:
                models = _variants(model, cause)
            starts = [None if base is None else (base.model.parameter_names, base.shape)]
            if cause in _ABSORBED and base is not None and base.model.causes:
                # The other causes' parameters, fitted without relaxation or without the
                # load cell's offset, may sit where they absorbed some of it: a fit from there
                # can stall far from the best, and the cause then looks to explain too little.
                starts.append(None)
                if cause == "force_offset":
                    # An offset is followed by the compression terms (an anisotropy's oblique
                    # factor in compression bent far from the tension one), and a fit from
                    # there, or from none, stays in that basin.
                    starts.append(_mirrored(base))
            keys.append(frozenset(models[0].causes))
            tasks.append((self.problem, models, starts, self.params.max_evaluations))
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


def _look_ahead(search: Search, current: ModelFit, trials: list[ModelFit], first: bool,
                noise: float) -> ModelFit | None:
    """When no single cause earns its place: the best of ``current`` plus two of the
    ``_LOOK_AHEAD`` best single additions, if it passes :func:`accepts` (two effects can each
    look like a third until both are in)."""
    top = sorted(trials, key=lambda f: f.heldout_rmse_n)[:_LOOK_AHEAD]
    added = [next(c for c in f.model.causes if c not in current.model.causes) for f in top]
    jobs = [(top[i], added[j]) for i in range(len(top)) for j in range(i + 1, len(top))
            if not {added[i], added[j]} >= set(EXCLUSIVE) and added[j] not in top[i].model.causes]
    if not jobs:
        return None
    best = min(search.run(jobs), key=lambda f: f.heldout_rmse_n)
    tests = search.problem.tests
    return best if accepts(best, current, first, noise, tests, search.params) else None


def _weaker(search: Search, current: ModelFit, noise: float,
            tests: tuple[MechanicalTest, ...]) -> ModelFit | None:
    """``current`` without its weakest cause, when that cause fails :func:`accepts` against
    the model without it; None when every cause holds (module docstring, 3). A lone cause is
    the first and stays, except a non-linear viscoelasticity: it must earn its non-linearity
    against the quasi-linear kind, alone and with each other cause added (a relaxed fraction
    that grows with strain stiffens the slow tests, and stands in for strain stiffening); when
    it fails one, the best of them takes its place."""
    causes = tuple(c for c in current.model.causes
                   if len(current.model.causes) > 1 or c == EXCLUSIVE[1])
    if not causes:
        return None
    without = search.run([(current, c) for c in causes])
    failing = [fit for fit in without
               if not accepts(current, fit, False, noise, tests, search.params)]
    if EXCLUSIVE[1] in causes:
        linear = without[causes.index(EXCLUSIVE[1])]
        alternatives = [linear, *search.run([(linear, c) for c in CAUSES
                                             if c not in linear.model.causes
                                             and c not in EXCLUSIVE])]
        failing = [fit for fit in failing if fit is not linear]
        if not all(accepts(current, f, False, noise, tests, search.params)
                   for f in alternatives):
            failing.append(min(alternatives, key=lambda f: f.heldout_rmse_n))
    return min(failing, key=lambda f: f.heldout_rmse_n) if failing else None


_Path = tuple[ModelFit, list[ModelFit], list[str]]


@dataclass(frozen=True)
class Swap:
    """One model the second look tried: the selected cause ``removed``, ``added`` in its
    place, the fit, and whether it was kept."""

    removed: str
    added: str
    fit: Any
    kept: bool

    def to_json(self) -> dict[str, Any]:
        """The JSON's ``second_look`` entry."""
        return {"removed": self.removed, "added": self.added,
                **determined("heldout_rmse_N", self.fit.heldout_rmse_n, NOT_PREDICTED),
                "kept": self.kept}


def forward(search: Search, start: ModelFit, trials: list[ModelFit], noise: float,
             order: list[str] | None = None) -> _Path:
    """The stepwise search (module docstring, 2 and 3) from ``start`` over ``trials``
    (``start`` plus each cause): the final fit, the fit after each step, the causes in the
    order they came. Where it stops with more than noise left (:func:`unexplained`), it
    takes a second look (:func:`_swapped`) and goes on from a swap that earns its place."""
    params, tests = search.params, search.problem.tests
    current, steps, order = start, [], list(order or [])
    visited = {frozenset(start.model.causes)}
    while True:
        while trials:
            best = min(trials, key=lambda f: f.heldout_rmse_n)
            if not accepts(best, current, not order, noise, tests, params):
                best = _look_ahead(search, current, trials, not order, noise)
                if best is None:
                    break
            order, current = _reordered(order, current, best), best
            while (weaker := _weaker(search, current, noise, tests)) is not None:
                order, current = _reordered(order, current, weaker), weaker
            if frozenset(current.model.causes) in visited:
                break
            visited.add(frozenset(current.model.causes))
            steps.append(current)
            trials = _additions(search, current, order)
        swapped = _swapped(search, current, noise, visited)
        if swapped is None:
            return current, steps, order
        order, current = _reordered(order, current, swapped), swapped
        visited.add(frozenset(current.model.causes))
        steps.append(current)
        trials = _additions(search, current, order)


def _swapped(search: Search, current: ModelFit, noise: float,
             visited: set[frozenset[str]]) -> ModelFit | None:
    """The second look, where ``current`` leaves more than noise: each selected cause
    swapped for each catalogue cause the model lacks (every remaining cause beside the
    selected ones was tried as a step already). A cause can stand in for another well enough
    to win a step (a plasticity's set for a load cell's offset), and the other then adds too
    little beside it. The swap with the least held-out error is kept when it explains more
    than ``current`` and its new cause passes :func:`accepts` against the model without it;
    every swap tried is recorded in ``search.swaps`` (once: a second start that ends where
    the first did looks again at the same swaps, already fitted)."""
    params, tests = search.params, search.problem.tests
    causes = tuple(current.model.causes)
    if not causes or not unexplained(current, noise, params, tests):
        return None
    without = search.run([(current, c) for c in causes])
    jobs = [(fit, removed, added) for fit, removed in zip(without, causes, strict=True)
            for added in search.catalogue if added not in causes
            and not {added, removed} >= set(EXCLUSIVE)
            and frozenset((*fit.model.causes, added)) not in visited]
    swaps = search.run([(fit, added) for fit, _, added in jobs])
    passing = [swap for swap, (fit, _, _) in zip(swaps, jobs, strict=True)
               if swap.heldout_rmse_n < current.heldout_rmse_n and swap.bic < current.bic
               and accepts(swap, fit, len(causes) == 1, noise, tests, params)]
    best = min(passing, key=lambda f: f.heldout_rmse_n, default=None)
    tried = {(s.removed, s.added, frozenset(s.fit.model.causes)) for s in search.swaps}
    search.swaps += [Swap(removed, added, swap, swap is best)
                     for swap, (_, removed, added) in zip(swaps, jobs, strict=True)
                     if (removed, added, frozenset(swap.model.causes)) not in tried]
    return best


def _reordered(order: list[str], previous: ModelFit, following: ModelFit) -> list[str]:
    """``order`` for the step from ``previous`` to ``following``: the causes kept, in their
    order, then those added."""
    return [c for c in order if c in following.model.causes] + [
        c for c in following.model.causes if c not in previous.model.causes]


def _additions(search: Search, current: ModelFit, order: list[str]) -> list[ModelFit]:
    """``current`` with each cause it lacks added (no quasi-linear viscoelasticity once the
    non-linear kind is named), fitted."""
    return search.run([(current, c) for c in search.catalogue if c not in current.model.causes
                       and not (c == EXCLUSIVE[0] and EXCLUSIVE[1] in order)])


def second_start(search: Search, baseline: ModelFit, candidates: list[ModelFit],
                  noise: float, first: _Path) -> _Path:
    """When the search ends with structure left (``first``): the search again from the
    runner-up single cause, kept if it explains the set with less held-out error. One cause
    can stand in for two others (a stiffening for an asymmetry under a load-cell offset)
    well enough to win the first step, and the two then never meet; the runner-up is often
    one of them."""
    params, tests = search.params, search.problem.tests
    chosen = set(first[2][:1])
    runner = min((f for f in candidates if not chosen & set(f.model.causes)),
                 key=lambda f: f.heldout_rmse_n, default=None)
    if runner is None or not accepts(runner, baseline, True, noise, tests, params):
        return first
    order = list(runner.model.causes)
    current, steps, order = forward(search, runner, _additions(search, runner, order), noise,
                                    order)
    if (current.heldout_rmse_n < first[0].heldout_rmse_n
            and not unexplained(current, noise, params, tests)):
        return current, [runner, *steps], order
    return first


def unexplained(fit: ModelFit, noise: float, params: DiagnosisParams,
                 tests: tuple[MechanicalTest, ...]) -> bool:
    """Whether ``fit`` leaves more than noise, with structure (module docstring, 4)."""
    return (fit.heldout_rmse_n > params.unexplained_ratio * noise
            and structure(fit, tests) > params.structure_correlation)
