"""Diagnosis of a set's cut tests: the cut baseline, the causes of the cut catalogue
(:mod:`cell.diagnosis.cut.causes`), the extended cutting model and the gain on held-out tests.

The search is the engine's (:func:`cell.diagnosis.engine.selection.forward`, with its
look-ahead, backward drops and second start, and :func:`cell.diagnosis.engine.acceptance.accepts`
judging each cause) walking the cut catalogue: :class:`CutSearch` fits the models it asks for
on the reduced model of a cut (:mod:`cell.diagnosis.cut.fitting`). The noise is the uniaxial
estimate (:func:`cell.diagnosis.engine.outcome.force_noise_n`) over each force channel.

A depth where the toughness steps (``layered_toughness``) gives a fit no gradient to follow
between samples: the boundary is put where it fits best among every depth between two that
the edges cut at (:func:`cell.diagnosis.cut.fitting.best_layer_depth`, the linear parameters
solved at each, all at once), the other parameters fitted, the boundary put again and the
whole fitted with its held-out predictions once.

Usage::

    result = diagnose_cuts(data.block, data.blade, data.cut_tests)
    result.causes  # cut catalogue names, most important first
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cell.diagnosis.cut.causes import (
    FACE_PRESSURE_PA,
    REGISTRY,
    CutCandidate,
    catalogue,
    cause_of,
    source_checks,
)
from cell.diagnosis.cut.fitting import CutFit, CutProblem, best_layer_depth, fit_cut, refine
from cell.diagnosis.cut.residuals import (
    ResidualTrend,
    ScalesBetweenTests,
    cut_residual_trends,
    scales_between_tests,
)
from cell.diagnosis.engine.acceptance import Rules, Tests, improved_fraction
from cell.diagnosis.engine.fit import Fit
from cell.diagnosis.engine.outcome import Evidence, SearchOutcome, force_noise_n
from cell.diagnosis.engine.search import Search
from cell.diagnosis.engine.selection import Swap, forward, second_start, unexplained
from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.specimen.causes import UNEXPLAINED
from cell.measure.cuts import Blade, Block, CutTest


def fit_best(problem: CutProblem, model: CutCandidate, start: np.ndarray,
             max_evaluations: int) -> CutFit:
    """``model`` fitted from ``start``; a layered model's boundary first put where it fits
    best with the start's other parameters, those fitted, the boundary put again where it
    fits best with them, and the whole fitted from there (module docstring)."""
    if "layered_toughness" in model.causes and model.layers == 2:
        shape, _ = refine(problem, model, best_layer_depth(problem, model, start),
                          max_evaluations)
        start = best_layer_depth(problem, model, shape)
    return fit_cut(problem, model, start, max_evaluations)


def _judged(richer: Fit, poorer: Fit, tests: Tests) -> list[int]:
    """The tests on which ``richer`` is judged against ``poorer``: the sawing ones
    (:attr:`~cell.diagnosis.cut.fitting.CutSeries.slides`) when all it adds acts only while
    the edge slides along itself (a press cut's held-out error can only tie with and without
    it, and would count against it); every test otherwise, and when no test saws."""
    added = set(richer.model.causes) - set(poorer.model.causes)
    sliding = bool(added) and all(REGISTRY[c].needs_sliding for c in added)
    shown = [i for i, test in enumerate(tests) if test.slides] if sliding else []
    return shown or list(range(len(tests)))


class CutSearch(Search):
    """The engine's :class:`~cell.diagnosis.engine.search.Search` over the cut catalogue,
    fitting cutting models (:func:`fit_best`) in this process; no pair of cut causes
    excludes each other.

    Example:
        >>> CutSearch.rules.offsets
        ('blade_force_offset',)
    """

    rules = Rules(offsets=("blade_force_offset",), judged=_judged)
    fit_model = staticmethod(fit_best)

    @property
    def catalogue(self) -> tuple[str, ...]:  # type: ignore[override]
        """The registered cut causes (:func:`cell.diagnosis.cut.causes.registry.catalogue`)."""
        return catalogue()


@dataclass(frozen=True, eq=False)
class CutDiagnosis(SearchOutcome):
    """What :func:`diagnose_cuts` found: as :class:`~cell.diagnosis.specimen.diagnosis.Diagnosis`
    for the cut tests (``noise_n``, ``baseline``, ``candidates``, ``steps``, ``extended``,
    ``causes``, ``evidence``, ``params``); each cause's evidence is the uniaxial diagnosis's
    :class:`~cell.diagnosis.engine.outcome.Evidence`, its ``without`` a cut fit."""

    noise_n: float
    baseline: CutFit
    candidates: tuple[CutFit, ...]
    steps: tuple[CutFit, ...]
    extended: CutFit
    causes: tuple[str, ...]
    evidence: tuple[Evidence, ...] = ()
    params: DiagnosisParams = field(default_factory=DiagnosisParams)
    swaps: tuple[Swap, ...] = ()
    residual_trends: tuple[ResidualTrend, ...] = ()
    between_tests: ScalesBetweenTests | None = None

    def to_json(self) -> dict[str, Any]:
        """The contract's JSON, plus the evidence of each cause (as the uniaxial
        diagnosis's), the fitted parameters checked against their sources' ranges
        (:func:`~cell.diagnosis.cut.causes.candidate.source_checks`) and, where ``unexplained``
        stands, the residual's trends (the strongest first) and the factor per test on the
        prediction (``residual_test_scales``, null otherwise), both of
        :mod:`cell.diagnosis.cut.residuals`."""
        scales = self.between_tests
        return {**super().to_json(), "evidence": [e.to_json() for e in self.evidence],
                "source_ranges": source_checks(self.extended.params),
                "residual_trends": [t.to_json() for t in self.residual_trends],
                "residual_test_scales": None if scales is None else scales.to_json()}


def _evidence(search: CutSearch, final: CutFit, order: list[str]) -> tuple[Evidence, ...]:
    """Per cause of ``final``: its held-out RMSE with and without the cause (the search's
    fit without it, fitted now if the search has none), the share of tests the cause
    improves, and the cause's own fitted parameters with their 95 % intervals (for
    ``blade_friction`` the friction coefficient at the model's face pressure too)."""
    evidence = []
    fitted = final.fitted
    for cause in order:
        kept = frozenset(c for c in final.model.causes if c != cause)
        without = search.fits.get(kept) or search.run([(final, cause)])[0]
        own = {n: v for n, v in fitted.items() if cause_of(n, final.model) == cause}
        if cause == "blade_friction":
            own["face_friction"] = tuple(v / final.model.face_pressure_pa
                                         for v in own["face_shear_pa"])
        evidence.append(Evidence(cause, final.heldout_rmse_n, without.heldout_rmse_n,
                                 improved_fraction(final, without, search.problem.tests),
                                 own, without))
    return tuple(evidence)


def diagnose_cuts(block: Block, blade: Blade, tests: tuple[CutTest, ...],
                  params: DiagnosisParams | None = None,
                  face_pressure_pa: float = FACE_PRESSURE_PA,
                  on_fit: Callable[[int], object] | None = None) -> CutDiagnosis:
    """Diagnose a set's cut tests (module docstring); ``face_pressure_pa`` is the pressure a
    fitted face shear stress is divided by (the material's, where it has a cutting model);
    ``on_fit`` is called with 1 after each fit (progress).

    Example:
        >>> from cell.diagnosis.cut.reduced import reduced_cut_forces
        >>> from cell.tissue.cutmodel import CuttingParams
        >>> block = Block((0.06, 0.04, 0.03))
        >>> blade = Blade(0.12, 0.0015, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
        >>> t = np.linspace(0.0, 5.0, 200)
        >>> tests = []
        >>> for k, speed in enumerate((0.004, 0.006, 0.008)):
        ...     edge = np.column_stack([0.03 + 0 * t, 0.02 + 0 * t, 0.032 - speed * t])
        ...     force = reduced_cut_forces(CutTest("c", t, edge, edge), block, blade,
        ...                          CuttingParams(800.0)).total_n + [0.0, 0.0, 1.5]
        ...     noisy = force + np.random.default_rng(k).normal(0.0, 0.05, force.shape)
        ...     tests.append(CutTest(f"c{k}", t, edge, noisy))
        >>> diagnose_cuts(block, blade, tuple(tests)).causes
        ('blade_force_offset',)
    """
    params = DiagnosisParams() if params is None else params
    problem = CutProblem.of(block, blade, tests, 2 * params.fit_samples)
    root = CutCandidate((), problem.reference_speed_m_s(), block.top_z_m,
                        face_pressure_pa=face_pressure_pa)
    noise = force_noise_n([channel for test in tests for channel in test.force_n.T])
    search = CutSearch(problem, params, root)
    search.on_fit = on_fit
    baseline = search.run([(None, None)])[0]
    candidates = search.run([(baseline, c) for c in search.catalogue])
    current, steps, order = forward(search, baseline, candidates, noise)
    if unexplained(current, noise, params, problem.tests):
        current, steps, order = second_start(search, baseline, candidates, noise,
                                             (current, steps, order))
    causes, trends, scales = tuple(order), (), None
    if unexplained(current, noise, params, problem.tests):
        causes += (UNEXPLAINED,)
        trends = cut_residual_trends(tests, block, blade, current.heldout_force_n)
        scales = scales_between_tests(tests, block, blade, current.heldout_force_n)
    return CutDiagnosis(noise, baseline, tuple(candidates), tuple(steps), current, causes,
                        _evidence(search, current, list(order)), params, tuple(search.swaps),
                        trends, scales)
