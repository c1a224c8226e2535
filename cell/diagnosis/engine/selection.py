"""The selection of a diagnosis's causes on any family's search
(:class:`~cell.diagnosis.engine.search.Search`; :mod:`cell.diagnosis.specimen.diagnosis`, its
module docstring, 2 to 4): the forward steps with their look-ahead and backward drops, the
second look and the second start from the runner-up cause.

Usage::

    baseline = search.run([(None, None)])[0]
    candidates = search.run([(baseline, c) for c in search.catalogue])
    final, steps, order = forward(search, baseline, candidates, noise)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from cell.diagnosis.engine.acceptance import accepts, structure
from cell.diagnosis.engine.determined import NOT_PREDICTED, determined
from cell.diagnosis.engine.fit import Fit
from cell.diagnosis.engine.search import Search
from cell.diagnosis.engine.settings import DiagnosisParams

# Single additions whose pairs the search tries when none passes alone.
_LOOK_AHEAD = 3


def _exclusive(search: Search, causes: set[str]) -> bool:
    """Whether ``causes`` hold both of the family's mutually exclusive pair."""
    return bool(search.exclusive) and causes >= set(search.exclusive)


def _accepts(search: Search, richer: Fit, poorer: Fit, first: bool, noise: float) -> bool:
    """:func:`~cell.diagnosis.engine.acceptance.accepts` with the search's tests, settings
    and family rules."""
    return accepts(richer, poorer, first=first, noise=noise, tests=search.problem.tests,
                   params=search.params, rules=search.rules)


def _look_ahead(search: Search, current: Fit, trials: list[Fit], first: bool,
                noise: float) -> Fit | None:
    """When no single cause earns its place: the best of ``current`` plus two of the
    ``_LOOK_AHEAD`` best single additions, if it passes :func:`accepts` (two effects can each
    look like a third until both are in)."""
    top = sorted(trials, key=lambda f: f.heldout_rmse_n)[:_LOOK_AHEAD]
    added = [next(c for c in f.model.causes if c not in current.model.causes) for f in top]
    jobs = [(top[i], added[j]) for i in range(len(top)) for j in range(i + 1, len(top))
            if not _exclusive(search, {added[i], added[j]})
            and added[j] not in top[i].model.causes]
    if not jobs:
        return None
    best = min(search.run(jobs), key=lambda f: f.heldout_rmse_n)
    return best if _accepts(search, best, current, first, noise) else None


def _weaker(search: Search, current: Fit, noise: float) -> Fit | None:
    """``current`` without its weakest cause, when that cause fails :func:`accepts` against
    the model without it; None when every cause holds (module docstring, 3). A lone cause is
    the first and stays, except a non-linear viscoelasticity: it must earn its non-linearity
    against the quasi-linear kind, alone and with each other cause added (a relaxed fraction
    that grows with strain stiffens the slow tests, and stands in for strain stiffening); when
    it fails one, the best of them takes its place (the second of the family's exclusive
    pair, :attr:`~cell.diagnosis.engine.search.Search.exclusive`)."""
    richer = search.exclusive[1] if search.exclusive else None
    causes = tuple(c for c in current.model.causes
                   if len(current.model.causes) > 1 or c == richer)
    if not causes:
        return None
    without = search.run([(current, c) for c in causes])
    failing = [fit for fit in without
               if not _accepts(search, current, fit, False, noise)]
    if richer in causes:
        linear = without[causes.index(richer)]
        alternatives = [linear, *search.run([(linear, c) for c in search.catalogue
                                             if c not in linear.model.causes
                                             and c not in search.exclusive])]
        failing = [fit for fit in failing if fit is not linear]
        if not all(_accepts(search, current, f, False, noise)
                   for f in alternatives):
            failing.append(min(alternatives, key=lambda f: f.heldout_rmse_n))
    return min(failing, key=lambda f: f.heldout_rmse_n) if failing else None


_Path = tuple[Fit, list[Fit], list[str]]


@dataclass(frozen=True)
class Swap:
    """One model the second look tried: the selected cause ``removed``, ``added`` in its
    place, the fit, and whether it was kept."""

    removed: str
    added: str
    fit: Fit
    kept: bool

    def to_json(self) -> dict[str, Any]:
        """The JSON's ``second_look`` entry."""
        return {"removed": self.removed, "added": self.added,
                **determined("heldout_rmse_N", self.fit.heldout_rmse_n, NOT_PREDICTED),
                "kept": self.kept}


def forward(search: Search, start: Fit, trials: list[Fit], noise: float,
             order: list[str] | None = None) -> _Path:
    """The stepwise search (module docstring, 2 and 3) from ``start`` over ``trials``
    (``start`` plus each cause): the final fit, the fit after each step, the causes in the
    order they came. Where it stops with more than noise left (:func:`unexplained`), it
    takes a second look (:func:`_swapped`) and goes on from a swap that earns its place."""
    current, steps, order = start, [], list(order or [])
    visited = {frozenset(start.model.causes)}
    while True:
        while trials:
            best = min(trials, key=lambda f: f.heldout_rmse_n)
            if not _accepts(search, best, current, not order, noise):
                best = _look_ahead(search, current, trials, not order, noise)
                if best is None:
                    break
            order, current = _reordered(order, current, best), best
            while (weaker := _weaker(search, current, noise)) is not None:
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


def _swapped(search: Search, current: Fit, noise: float,
             visited: set[frozenset[str]]) -> Fit | None:
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
            and not _exclusive(search, {added, removed})
            and frozenset((*fit.model.causes, added)) not in visited]
    swaps = search.run([(fit, added) for fit, _, added in jobs])
    passing = [swap for swap, (fit, _, _) in zip(swaps, jobs, strict=True)
               if swap.heldout_rmse_n < current.heldout_rmse_n and swap.bic < current.bic
               and _accepts(search, swap, fit, len(causes) == 1, noise)]
    best = min(passing, key=lambda f: f.heldout_rmse_n, default=None)
    tried = {(s.removed, s.added, frozenset(s.fit.model.causes)) for s in search.swaps}
    search.swaps += [Swap(removed, added, swap, swap is best)
                     for swap, (_, removed, added) in zip(swaps, jobs, strict=True)
                     if (removed, added, frozenset(swap.model.causes)) not in tried]
    return best


def _reordered(order: list[str], previous: Fit, following: Fit) -> list[str]:
    """``order`` for the step from ``previous`` to ``following``: the causes kept, in their
    order, then those added."""
    return [c for c in order if c in following.model.causes] + [
        c for c in following.model.causes if c not in previous.model.causes]


def _additions(search: Search, current: Fit, order: list[str]) -> list[Fit]:
    """``current`` with each cause it lacks added (no quasi-linear viscoelasticity once the
    non-linear kind is named), fitted."""
    return search.run([(current, c) for c in search.catalogue if c not in current.model.causes
                       and not (search.exclusive[:1] == (c,) and search.exclusive[1] in order)])


def second_start(search: Search, baseline: Fit, candidates: list[Fit],
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
    if runner is None or not _accepts(search, runner, baseline, True, noise):
        return first
    order = list(runner.model.causes)
    current, steps, order = forward(search, runner, _additions(search, runner, order), noise,
                                    order)
    if (current.heldout_rmse_n < first[0].heldout_rmse_n
            and not unexplained(current, noise, params, tests)):
        return current, [runner, *steps], order
    return first


def unexplained(fit: Fit, noise: float, params: DiagnosisParams,
                 tests: tuple[Any, ...]) -> bool:
    """Whether ``fit`` leaves more than noise, with structure (module docstring, 4)."""
    return (fit.heldout_rmse_n > params.unexplained_ratio * noise
            and structure(fit, tests) > params.structure_correlation)
