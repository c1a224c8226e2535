"""The search of a set with repeats (tests under equal conditions,
:mod:`cell.diagnosis.specimen.repeats`), each cause judged on held-out errors with the specimens'
scatter within each group of repeats taken out.

Where each test is another specimen, a model's held-out error is mostly the specimens' spread,
the same with any cause or without: a real effect then lowers it by less than a cause must, and
structure reads as ``unexplained``. What a material cause changes shows between conditions,
not between the specimens of one condition. So each held-out prediction is judged at its own
specimen's factor relative to its group: ``exp(u_k - mu_g)`` with ``u_k`` the log factor that
fits test k best (:func:`cell.diagnosis.specimen.spread.log_factors`) and ``mu_g`` the mean over its
group. The factors between conditions stay for the causes to explain (anisotropy is a factor between
angles), and a test without a repeat keeps its prediction. Without a spread the factors are
noise and the judgement is the plain one.

Where the tests name their specimens (:mod:`cell.diagnosis.specimen.specimenids`), each
held-out prediction (the fit to the other specimens) is judged at its specimen's own factor,
one factor for all of the specimen's tests (:func:`at_own_factors` with ``pooled``): the
spread between specimens is taken out, and what differs between one specimen's conditions
stays for the causes.

The fits themselves are the search's own; only what :meth:`RepeatSearch.run` returns to the
steps is judged so, and :meth:`RepeatSearch.plain` gives back the fit a judged one came from.

Usage::

    search = RepeatSearch(problem, params, root, pool, repeat_groups(tests, specimen))
    baseline = search.run([(None, None)])[0]  # judged between repeats
    search.plain(baseline).heldout_rmse_n     # the plain held-out error
"""

from __future__ import annotations

from concurrent.futures import Executor
from dataclasses import replace

import numpy as np

from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.specimen.causes import CandidateMaterial
from cell.diagnosis.specimen.fitting import ModelFit, Problem
from cell.diagnosis.specimen.search import SpecimenSearch
from cell.diagnosis.specimen.spread import log_factors
from cell.measure.specimens import MechanicalTest


class RepeatSearch(SpecimenSearch):
    """A :class:`~cell.diagnosis.specimen.search.SpecimenSearch` whose fits are judged between
    repeats (module docstring); ``groups`` are the tests under equal conditions, or, with
    ``pooled``, the tests of each named specimen; ``judging`` off returns the plain fits.

    Example:
        >>> from cell.measure.specimens import load_measurement_set
        >>> from cell.diagnosis.specimen.repeats import repeat_groups
        >>> data = load_measurement_set("assets/measured/beef_round_example")
        >>> search = RepeatSearch(Problem.of(data.specimen, data.tests, 32),
        ...                       DiagnosisParams(workers=1), CandidateMaterial(()), None,
        ...                       repeat_groups(data.tests, data.specimen))
        >>> search.judging  # the example set repeats no condition
        False
    """

    def __init__(self, problem: Problem, params: DiagnosisParams, root: CandidateMaterial,
                 pool: Executor | None, groups: list[list[int]], pooled: bool = False) -> None:
        super().__init__(problem, params, root, pool)
        self.pooled = pooled
        self.groups = groups if pooled else [g for g in groups if len(g) >= 2]
        self.judging = bool(self.groups)
        # Keyed by id, each with the fit it is keyed by (kept alive, so its id is not reused).
        self._judged: dict[int, tuple[ModelFit, ModelFit]] = {}
        self._plain: dict[int, tuple[ModelFit, ModelFit]] = {}

    def run(self, jobs: list[tuple[ModelFit | None, str | None]]) -> list[ModelFit]:
        """:meth:`SpecimenSearch.run`, each fit judged between repeats while ``judging``."""
        fits = super().run([(None if base is None else self.plain(base), cause)
                            for base, cause in jobs])
        return [self.judged(f) for f in fits] if self.judging else fits

    def plain(self, fit: ModelFit) -> ModelFit:
        """The search's own fit behind ``fit`` (``fit`` when it is one)."""
        return self._plain[id(fit)][1] if id(fit) in self._plain else fit

    def judged(self, fit: ModelFit) -> ModelFit:
        """``fit`` with its held-out predictions at each specimen's factor within its group."""
        if id(fit) not in self._judged:
            judged = at_own_factors(fit, self.problem.tests, self.groups, self.pooled)
            self._judged[id(fit)] = (fit, judged)
            self._plain[id(judged)] = (judged, fit)
        return self._judged[id(fit)][1]


def at_own_factors(fit: ModelFit, tests: tuple[MechanicalTest, ...],
                   groups: list[list[int]] | None, pooled: bool = False) -> ModelFit:
    """``fit`` with each held-out prediction at its specimen's factor relative to its group
    (module docstring; a test in no group keeps its prediction), or at its own factor outright
    when ``groups`` is None (what is left then is what no specimen's factor explains); with
    ``pooled``, each group is a named specimen and its tests share its one factor, outright."""
    u, _ = log_factors(tests, fit.heldout_force_n, fit.offset_n, 0.0)
    shift = u.copy() if groups is None else np.zeros(len(tests))
    for group in groups or []:
        shift[group] = (_pooled_log_factor(fit, tests, group) if pooled
                        else u[group] - u[group].mean())
    heldout = tuple(fit.offset_n + np.exp(s) * (h - fit.offset_n)
                    for s, h in zip(shift, fit.heldout_force_n, strict=True))
    errors = np.concatenate([h - t.force_n for h, t in zip(heldout, tests, strict=True)])
    return replace(fit, heldout_force_n=heldout,
                   heldout_rmse_n=float(np.sqrt(np.mean(errors**2))))


def _pooled_log_factor(fit: ModelFit, tests: tuple[MechanicalTest, ...],
                       group: list[int]) -> float:
    """The one log factor on the held-out material forces of ``group`` that fits them best
    together (:func:`cell.diagnosis.specimen.spread.log_factors`, pooled)."""
    material = [fit.heldout_force_n[k] - fit.offset_n for k in group]
    residual = [tests[k].force_n - fit.heldout_force_n[k] for k in group]
    energy = max(sum(float(m @ m) for m in material), 1e-300)
    gain = sum(float(m @ r) for m, r in zip(material, residual, strict=True))
    return float(np.log(max(1.0 + gain / energy, 1e-3)))
