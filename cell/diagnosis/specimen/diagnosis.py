"""Diagnosis of a measurement set: where the simulation is wrong, the causes, the extended
material, the gain on held-out tests, and the evidence for each cause.

1. The baseline (:class:`~cell.diagnosis.specimen.causes.candidate.CandidateMaterial` with no
   cause: linear,
   isotropic, rate-independent springs) is fitted to every test
   (:mod:`cell.diagnosis.specimen.fitting`:
   each test simulated with the muscles' own spring law, errors measured leave-one-test-out;
   shear and biaxial tests are fitted with the uniaxial ones, each one series of the fit, and
   each cause's evidence is then given per mode: :mod:`cell.diagnosis.specimen.planeseries`).
2. A stepwise search, forward with backward steps, over combinations of the catalogue's causes:
   every cause not in the current model is added to it and fitted (``nonlinear_viscoelasticity``
   replaces ``viscoelasticity``, never joins it); the best is kept when it passes
   :func:`accepts` against the current model: it lowers the held-out mean square error by more
   than ``min_variance_drop`` noise variances (the noise from the data: second differences of
   each test's force) *and* lowers the Bayesian information criterion, cuts the held-out RMSE
   to at most ``max_rmse_ratio`` of what it was (``later_rmse_ratio`` from the second cause
   on), and (from the second on) lowers it on at least ``min_improved_fraction`` of the tests.
   When no single cause passes, pairs of the three best are tried (look-ahead), the best
   pair kept when it passes the same test.
3. After each addition every other cause must still pass the same test against the model
   without it (for ``nonlinear_viscoelasticity``: with ``viscoelasticity`` in its place); the
   weakest that does not is dropped, and so on. A cause stays named only while removing it
   raises the held-out error beyond the noise; those fits are the evidence of each cause
   (:class:`Evidence`). ``nonlinear_viscoelasticity`` in place of ``viscoelasticity`` is
   judged on the ramp-and-hold tests alone (mode ``relaxation``), where a relaxed fraction that
   depends on the strain shows.
4. When the final held-out error is still more than ``unexplained_ratio`` times the noise and
   its residuals are correlated (lag-one autocorrelation above ``structure_correlation``),
   ``unexplained`` is added, unless the search run again from the runner-up single cause
   ends with less held-out error and no structure left (one cause can stand in for two others
   well enough to win the first step; the second path is kept then).
5. Where tests repeat a condition (:mod:`cell.diagnosis.specimen.repeats`: mode, angle and
   displacement path, never names), each is another specimen: the steps judge every cause with the
   specimens' scatter within each group of repeats taken out
   (:mod:`cell.diagnosis.specimen.repeatsearch`), and ``specimen_variability`` is named when the
   repeats disagree beyond the noise, its spread fitted as a random effect
   (:mod:`cell.diagnosis.specimen.spread`). Where the tests name their specimens (the
   ``specimen`` column: two or more, one of them with two or more tests), the held-out
   scores leave whole specimens out, the steps judge each cause at each specimen's own
   factor, and the spread is estimated across the specimens, one modulus factor each
   (:mod:`cell.diagnosis.specimen.specimenids`).
6. Each held-out prediction of the extended model gets a 90 % interval holding the specimen
   spread, the parameters' uncertainty and the model's discrepancy
   (:mod:`cell.diagnosis.specimen.intervals`), and the share of held-out samples they cover.

Candidates are fitted side by side in ``workers`` processes (default: every core). Usage::

    result = diagnose(load_measurement_set("assets/measured/beef_round_example"))
    result.causes  # catalogue names, most important first

Example:
    >>> from cell.measure.specimens import load_measurement_set
    >>> data = load_measurement_set("assets/measured/beef_round_example")
    >>> round(noise_n(data) * 1e3, 1)  # mN: the set's stated force noise is 1 mN
    1.0
"""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from multiprocessing import get_context
from typing import Any

import numpy as np

from cell.diagnosis.engine.acceptance import improved_fraction
from cell.diagnosis.engine.determined import (
    shown,
)
from cell.diagnosis.engine.outcome import Evidence, SearchOutcome, force_noise_n
from cell.diagnosis.engine.search import Search
from cell.diagnosis.engine.selection import Swap, forward, second_start, unexplained
from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.specimen.causes import (
    EXCLUSIVE,
    SPECIMEN_VARIABILITY,
    UNEXPLAINED,
    CandidateMaterial,
    cause_of,
)
from cell.diagnosis.specimen.fitting import ModelFit, Problem
from cell.diagnosis.specimen.intervals import PredictionIntervals, prediction_intervals
from cell.diagnosis.specimen.planeseries import Series, fitted_series, per_mode_rmse
from cell.diagnosis.specimen.repeats import repeat_groups
from cell.diagnosis.specimen.repeatsearch import RepeatSearch, at_own_factors
from cell.diagnosis.specimen.specimenids import specimen_folds, spread_by_specimen
from cell.diagnosis.specimen.spread import SpecimenSpread, specimen_spread
from cell.errors import DiagnosisError
from cell.measure.shearbiaxial import SHEAR_MODE
from cell.measure.specimens import MeasurementSet, MechanicalTest

_RELAXATION_TERMS = 2


@dataclass(frozen=True, eq=False)
class Diagnosis(SearchOutcome):
    """What :func:`diagnose` found (module docstring).

    Attributes:
        measurements: the set.
        noise_n: the force noise estimated from the data, N.
        baseline: the baseline fit.
        candidates: each cause of the catalogue alone, fitted.
        steps: the model after each step of the search (an addition, with its drops).
        extended: the final model (the baseline when no cause is accepted).
        causes: accepted causes, most important first, then ``unexplained`` if it applies.
        evidence: per accepted cause, in the order of ``causes``.
        params: the settings it ran with.
        explored: every model the search fitted.
        specimen: the specimen spread between tests under equal conditions
            (:mod:`cell.diagnosis.specimen.spread`), or across named specimens
            (:mod:`cell.diagnosis.specimen.specimenids`).
        intervals: the extended model's held-out predictions with their 90 % intervals
            (:mod:`cell.diagnosis.specimen.intervals`).
        swaps: what the search's second look tried
            (:func:`cell.diagnosis.engine.selection.forward`).

    ``to_json()`` is the JSON that ``musclecell diagnose --out`` writes.
    """

    measurements: MeasurementSet
    noise_n: float
    baseline: ModelFit
    candidates: tuple[ModelFit, ...]
    steps: tuple[ModelFit, ...]
    extended: ModelFit
    causes: tuple[str, ...]
    evidence: tuple[Evidence, ...] = ()
    params: DiagnosisParams = field(default_factory=DiagnosisParams)
    explored: tuple[ModelFit, ...] = ()
    specimen: SpecimenSpread = field(default_factory=SpecimenSpread.absent)
    intervals: PredictionIntervals | None = None
    swaps: tuple[Swap, ...] = ()

    @property
    def series(self) -> tuple[Series, ...]:
        """The fitted tests, in the order of the fits' forces: the uniaxial ones, then the
        shear and biaxial ones (:mod:`cell.diagnosis.specimen.planeseries`)."""
        return fitted_series(self.measurements)

    def material_comment(self) -> str:
        """The comment lines on top of the extended material's file: where it comes from,
        the causes, the held-out errors and a rig offset left out of it."""
        extended = self.extended
        comment = (f"Extended material fitted by `musclecell diagnose` to "
                   f"{self.measurements.folder.name} ({self.measurements.specimen.name}).\n"
                   f"Model: {extended.model.name}; causes: {', '.join(self.causes) or 'none'}; "
                   f"held-out RMSE {shown(extended.heldout_rmse_n, '.4g')} N (baseline "
                   f"{shown(self.baseline.heldout_rmse_n, '.4g')} N).")
        if extended.model.has_offset:
            comment += (f"\nThe load cell read {extended.offset_n:.4g} N at rest: a rig effect, "
                        "not part of this material.")
        return comment

    def to_json(self) -> dict[str, Any]:
        """The diagnosis contract (docs/measured-data.md), plus the noise, the
        information criteria, the search's steps, the evidence of each cause, the specimen
        spread and the held-out predictions with their intervals."""
        intervals = {} if self.intervals is None else {"intervals": self.intervals.to_json()}
        return {**super().to_json(), "evidence": [e.to_json() for e in self.evidence],
                "specimen_variability": self.specimen.to_json(), **intervals}


def noise_n(measurements: MeasurementSet) -> float:
    """Force noise of a set, N: the median over tests of a robust spread of the force's second
    differences (``sqrt(6)`` times the noise for white noise)."""
    return force_noise_n([test.force_n for test in fitted_series(measurements)])


def _time_range_s(measurements: MeasurementSet) -> tuple[float, float]:
    """Relaxation times a fit may give: from a third of the shortest sample interval (faster
    ones act at once) to twice the longest test (slower ones never act)."""
    tests = fitted_series(measurements)
    shortest = min(float(np.median(np.diff(t.time_s))) for t in tests if len(t.time_s) > 1)
    longest = max(t.duration_s for t in tests)
    low = max(shortest / 3.0, 1e-3)
    return low, max(2.0 * longest, 10.0 * low)


def _stretch_range(measurements: MeasurementSet) -> tuple[float, float]:
    """The set's stretches, widened by 10% of their span and to contain 1. A simple shear
    stretches one diagonal and shortens the other by about as much: its strains count both
    ways (a shear-only set's springs are compressed too)."""
    tests = fitted_series(measurements)
    strains = np.concatenate([t.strain(measurements.specimen) for t in tests]
                             + [-t.strain(measurements.specimen) for t in tests
                                if t.mode.startswith(SHEAR_MODE)])
    margin = 0.1 * max(float(np.ptp(strains)), 0.01)
    return (max(1.0 + min(float(strains.min()), 0.0) - margin, 0.05),
            1.0 + max(float(strains.max()), 0.0) + margin)


def _reference_strain(measurements: MeasurementSet) -> float:
    """The strain a non-linear relaxed fraction is fitted at: the median of the tests' peak
    strains (within the set's strains, where the fraction is measured)."""
    return float(np.median([np.abs(t.strain(measurements.specimen)).max()
                            for t in fitted_series(measurements)]))


def _evidence(search: Search, final: ModelFit, order: list[str]) -> tuple[Evidence, ...]:
    """The evidence of each cause of ``final``, in ``order``."""
    tests = search.problem.tests
    evidence = []
    for cause in order:
        if final.model.causes == (cause,) and cause != EXCLUSIVE[1]:
            without = search.run([(None, None)])[0]
        else:
            without = search.run([(final, cause)])[0]
        names = final.model.parameter_names
        own = [i for i, n in enumerate(names) if cause_of(n, final.model) == cause]
        evidence.append(Evidence(
            cause, final.heldout_rmse_n, without.heldout_rmse_n,
            improved_fraction(final, without, tests),
            {names[i]: (float(final.shape[i]), *map(float, final.ci95[i])) for i in own},
            without, per_mode=_per_mode(final, without, tests)))
    return tuple(evidence)


def _per_mode(final: ModelFit, without: ModelFit, tests: tuple[Series, ...]
              ) -> dict[str, tuple[float, float]]:
    """Each mode's held-out RMSE with and without a cause, N, where the set holds shear or
    biaxial tests beside others (a uniaxial set's evidence is as it was)."""
    if all(isinstance(t, MechanicalTest) for t in tests):
        return {}
    with_, without_ = (per_mode_rmse(f.heldout_force_n, tests) for f in (final, without))
    return {mode: (with_[mode], without_[mode]) for mode in with_}


def diagnose(measurements: MeasurementSet, params: DiagnosisParams | None = None,
             on_fit: Callable[[int], object] | None = None) -> Diagnosis:
    """Diagnose ``measurements`` (module docstring); ``on_fit`` is called with 1 after each
    fit (progress).

    Raises:
        DiagnosisError: a set of one test (nothing to hold it out against), or the baseline
            or the extended model cannot run a test (which, and with which causes).
    """
    params = DiagnosisParams() if params is None else params
    tests = fitted_series(measurements)
    if len(tests) == 1:
        # Each test is predicted by the model fitted to the others: one alone has none.
        raise DiagnosisError(measurements.folder / "tests.csv", "test_id",
                             f"one test ({tests[0].test_id}): the diagnosis holds each test "
                             "out in turn, so it needs at least two")
    specimens = specimen_folds(tests)
    problem = Problem.of(measurements.specimen, tests, params.fit_samples, specimens)
    root = CandidateMaterial((), "exponential", _time_range_s(measurements), _RELAXATION_TERMS,
                             _stretch_range(measurements), oblique=True,
                             reference_strain=_reference_strain(measurements))
    noise = noise_n(measurements)
    # Spawned, not forked: a fork of a process whose numba (and MuJoCo, in the CLI) has
    # started threads can deadlock. The workers load the compiled spring law from numba's
    # on-disk cache rather than compiling it again.
    pool = (ProcessPoolExecutor(params.workers, mp_context=get_context("spawn"))
            if params.workers > 1 else None)
    groups = repeat_groups(tests, measurements.specimen)
    try:
        search = RepeatSearch(problem, params, root, pool, specimens or groups, bool(specimens))
        search.on_fit = on_fit
        baseline = search.run([(None, None)])[0]
        _require_runs(baseline)
        # At each named specimen's own factor, no spread is left between specimens.
        floor = noise if specimens else _judged_noise(search.plain(baseline), tests, noise,
                                                      groups)
        candidates = search.run([(baseline, c) for c in search.catalogue])
        current, steps, order = forward(search, baseline, candidates, floor)
        if unexplained(current, floor, params, tests):
            current, steps, order = second_start(search, baseline, candidates, floor,
                                                  (current, steps, order))
        # The evidence, the intervals and the report read the plain held-out errors.
        search.judging = False
        judged, current = current, search.plain(current)
        baseline, candidates = search.plain(baseline), [search.plain(c) for c in candidates]
        steps = [search.plain(f) for f in steps]
        evidence = _evidence(search, current, order)
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)
    _require_runs(current)
    order.sort(key=lambda c: -next(e.heldout_rmse_without_n for e in evidence if e.cause == c))
    evidence = tuple(sorted(evidence, key=lambda e: order.index(e.cause)))
    causes = tuple(order)
    spread = (spread_by_specimen(tests, current.fitted_force_n, current.offset_n, noise, groups,
                                 specimens) if specimens else
              specimen_spread(tests, current.fitted_force_n, current.offset_n, noise, groups))
    if spread.named:
        causes += (SPECIMEN_VARIABILITY,)
        evidence += (Evidence(SPECIMEN_VARIABILITY, judged.heldout_rmse_n,
                              current.heldout_rmse_n, improved_fraction(judged, current, tests),
                              {"log_modulus_sd": (spread.sd, *spread.ci95)}, current, judged),)
    # With a spread named, what no specimen's factor explains is left, against the noise
    # alone (the factors took the group means' spread too); else, what the steps judged.
    left = ((at_own_factors(current, tests, specimens or None, bool(specimens)), noise)
            if spread.named else (judged, floor))
    if unexplained(*left, params, tests):
        causes += (UNEXPLAINED,)
    intervals = prediction_intervals(problem, current, noise, spread.sd if spread.named else 0.0)
    return Diagnosis(measurements, noise, baseline, tuple(candidates), tuple(steps), current,
                     causes, evidence, params, tuple(search.fits.values()), spread, intervals,
                     tuple(search.swaps))


def _judged_noise(baseline: ModelFit, tests: tuple[MechanicalTest, ...], noise: float,
                  groups: list[list[int]]) -> float:
    """The noise a cause must explain more than, N: the force noise, and where the repeats
    show a specimen spread, the spread of each group's mean specimen (what the steps, judged
    within groups, still see between conditions: ``sd**2 / n`` of the material force squared,
    ``n`` the mean group size). The spread is read about the baseline: within groups its
    misfit drops out (:mod:`cell.diagnosis.specimen.spread`)."""
    spread = specimen_spread(tests, baseline.fitted_force_n, baseline.offset_n, noise, groups)
    if not spread.named:
        return noise
    size = float(np.mean([len(g) for g in groups if len(g) >= 2]))
    material = np.concatenate([f - baseline.offset_n for f in baseline.fitted_force_n])
    return math.sqrt(noise**2 + spread.sd**2 / size * float(np.mean(material**2)))


def _require_runs(model_fit: ModelFit) -> None:
    """Raise when the fitted material of ``model_fit`` cannot run a test of the set."""
    if model_fit.failed_test is not None:
        causes = ", ".join(model_fit.model.causes) or "none (the baseline)"
        raise DiagnosisError(None, model_fit.failed_test,
                             f"the fit with causes {causes} does not converge on test "
                             f"{model_fit.failed_test!r}: the specimen has no equilibrium")
