"""Diagnosis of a measurement set: where the simulation is wrong, the cause, the extended
material, the gain on held-out tests.

1. The baseline (:class:`~cell.rheology.causes.CandidateMaterial` with no cause: linear, isotropic,
   rate-independent springs) is fitted to every test, each simulated by
   :func:`~cell.rheology.specimen.simulate_test` with the muscles' own spring law.
2. Each cause of the catalogue is added to the current model and fitted; its error is measured
   leave-one-test-out: refitted without a test, then run on that test's every sample.
3. Causes are added one at a time, the one with the lowest held-out error first, while it
   lowers the held-out mean square error by more than ``min_variance_drop`` times the noise
   variance (the noise from the data: second differences of each test's force) *and* lowers
   the Bayesian information criterion, cuts the held-out RMSE to at most ``max_rmse_ratio``
   of what it was (``later_rmse_ratio`` from the second cause on), and (from the second on)
   lowers it on at least ``min_improved_fraction`` of the tests. When the final held-out
   error is still more than ``unexplained_ratio`` times the noise and its residuals are
   correlated (lag-one autocorrelation above ``structure_correlation``), ``unexplained`` is
   added.

Fits search the shape parameters with ``scipy.optimize.least_squares`` on up to
``fit_samples`` samples per test (picked evenly along time and displacement, turning points
kept) and solve for E and the offset in closed form; held-out errors use every sample.

A diagnosis takes minutes (``musclecell diagnose`` runs one); the examples here show its
cheap parts. Usage::

    result = diagnose(load_measurement_set("assets/measured/beef_round_example"))
    result.causes  # ('tension_compression_asymmetry', 'anisotropy', 'unexplained')

Example:
    >>> from cell.rheology.measured import load_measurement_set
    >>> data = load_measurement_set("assets/measured/beef_round_example")
    >>> round(noise_n(data) * 1e3, 1)  # mN: the set's stated force noise is 1 mN
    1.0
    >>> len(fit_samples(data.test("c00"), 32))
    32
"""

from __future__ import annotations

import math
from concurrent.futures import ProcessPoolExecutor
from contextlib import nullcontext
from dataclasses import dataclass, field, replace
from multiprocessing import get_context
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from cell.errors import DiagnosisError, DivergenceError, MaterialError
from cell.rheology.causes import CAUSES, UNEXPLAINED, CandidateMaterial
from cell.rheology.measured import MeasurementSet, MechanicalTest, Specimen
from cell.rheology.specimen import SpecimenLattice, simulate_test
from cell.tissue.material import MassSpringMaterial

# Modulus of the unit-modulus runs that E scales, Pa.
_REFERENCE_PA = 1.0e4
# Residual of a fit whose material has no equilibrium somewhere: far worse than any real fit.
_FAILED = 1.0e3
_RELAXATION_TERMS = 3


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
            of the springs to absorb (a lattice's plastic knee is slightly asymmetric, and an
            asymmetry then lowers every test's error by some 20%).
        min_improved_fraction: a cause after the first must also lower the held-out error of
            at least this fraction of the tests: a real effect shows in most tests, a cause
            that only absorbs in a few of them what the springs cannot follow is not one (the
            first cause may trade some tests for others while it stands in for the rest).
        unexplained_ratio: held-out RMSE over the noise above which left structure counts.
        structure_correlation: lag-one autocorrelation of held-out residuals above which
            they have structure.
        workers: processes fitting candidates side by side.
        max_evaluations: cap on a fit's simulations of the set.
        fold_evaluations: cap on a held-out refit's, which starts from the full fit.

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
    min_improved_fraction: float = 0.75
    unexplained_ratio: float = 2.0
    structure_correlation: float = 0.5
    workers: int = 1
    max_evaluations: int = 400
    fold_evaluations: int = 20

    def __post_init__(self) -> None:
        if self.fit_samples < 8:
            raise DiagnosisError(None, "fit_samples", f"must be >= 8, got {self.fit_samples}")
        if self.workers < 1:
            raise DiagnosisError(None, "workers", f"must be >= 1, got {self.workers}")


@dataclass(frozen=True, eq=False)
class ModelFit:
    """A material model fitted to a set, and its error on held-out tests.

    Attributes:
        model: the model (causes, stiffening law).
        shape: its shape parameters.
        modulus_pa: fitted small-strain modulus E (geometric mean of El and Et), Pa.
        offset_n: fitted load-cell offset, N (0 without ``force_offset``).
        material: the fitted material.
        rmse_n: RMSE on the fitted samples, N.
        heldout_rmse_n: RMSE of leave-one-test-out predictions over every sample, N.
        bic: Bayesian information criterion of the fit.
        fitted_force_n: per test, the fitted model's force at every sample, N.
        heldout_force_n: per test, the force predicted by the fit without that test, N.
    """

    model: CandidateMaterial
    shape: np.ndarray
    modulus_pa: float
    offset_n: float
    material: MassSpringMaterial
    rmse_n: float
    heldout_rmse_n: float
    bic: float
    fitted_force_n: tuple[np.ndarray, ...]
    heldout_force_n: tuple[np.ndarray, ...]

    @property
    def params(self) -> dict[str, float]:
        """Fitted parameters in SI units."""
        return self.model.reported(self.shape, self.modulus_pa, self.offset_n)

    def to_json(self) -> dict[str, Any]:
        """The contract's ``baseline`` / ``extended`` entry (plus ``bic``)."""
        return {"model": self.model.name, "params": self.params,
                "heldout_rmse_N": self.heldout_rmse_n, "bic": self.bic}


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """What :func:`diagnose` found (module docstring).

    Attributes:
        measurements: the set.
        noise_n: the force noise estimated from the data, N.
        baseline: the baseline fit.
        candidates: the baseline plus one cause, for each cause of the catalogue in order.
        steps: the fit after each accepted cause, in order.
        extended: the final model (the baseline when no cause is accepted).
        causes: accepted causes, most important first, then ``unexplained`` if it applies.

    ``to_json()`` is the JSON that ``musclecell diagnose --json`` writes.
    """

    measurements: MeasurementSet
    noise_n: float
    baseline: ModelFit
    candidates: tuple[ModelFit, ...]
    steps: tuple[ModelFit, ...]
    extended: ModelFit
    causes: tuple[str, ...]
    params: DiagnosisParams = field(default_factory=DiagnosisParams)

    @property
    def gain(self) -> float:
        """1 - extended over baseline held-out RMSE."""
        return 1.0 - self.extended.heldout_rmse_n / self.baseline.heldout_rmse_n

    def material_comment(self) -> str:
        """The comment lines on top of the extended material's file: where it comes from,
        the causes, the held-out errors and a rig offset left out of it."""
        extended = self.extended
        comment = (f"Extended material fitted by `musclecell diagnose` to "
                   f"{self.measurements.folder.name} ({self.measurements.specimen.name}).\n"
                   f"Model: {extended.model.name}; causes: {', '.join(self.causes) or 'none'}; "
                   f"held-out RMSE {extended.heldout_rmse_n:.4g} N (baseline "
                   f"{self.baseline.heldout_rmse_n:.4g} N).")
        if extended.model.has_offset:
            comment += (f"\nThe load cell read {extended.offset_n:.4g} N at rest: a rig effect, "
                        "not part of this material.")
        return comment

    def to_json(self) -> dict[str, Any]:
        """The diagnosis contract of ``spec/measured-data.md``, plus the noise, the
        information criteria and the order in which causes were accepted."""
        return {
            "baseline": self.baseline.to_json(),
            "causes": list(self.causes),
            "candidates": [
                {"cause": fit.model.causes[0], "params": fit.params,
                 "heldout_rmse_N": fit.heldout_rmse_n, "bic": fit.bic,
                 "selected": fit.model.causes[0] in self.causes}
                for fit in self.candidates
            ],
            "extended": self.extended.to_json(),
            "gain": self.gain,
            "noise_N": self.noise_n,
            "steps": [{"causes": list(fit.model.causes), "heldout_rmse_N": fit.heldout_rmse_n,
                       "bic": fit.bic} for fit in self.steps],
        }


def noise_n(measurements: MeasurementSet) -> float:
    """Force noise of a set, N: the median over tests of a robust spread of the force's second
    differences (``sqrt(6)`` times the noise for white noise)."""
    spreads = []
    for test in measurements.tests:
        second = np.diff(test.force_N, 2)
        if len(second) >= 3:
            spreads.append(1.4826 * np.median(np.abs(second - np.median(second))) / math.sqrt(6))
    return float(np.median(spreads)) if spreads else 0.0


def fit_samples(test: MechanicalTest, count: int) -> np.ndarray:
    """Indices of about ``count`` samples spread evenly along time and displacement, the first,
    the last and the displacement's turning points included."""
    # Imported here: only the parent picks samples, and scipy.signal would be half of every
    # spawned worker's start-up.
    from scipy.signal import find_peaks

    n = len(test.time_s)
    if n <= count:
        return np.arange(n)
    span = max(float(np.ptp(test.displacement_m)), 1e-300)
    travel = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(test.displacement_m)))]) / span
    elapsed = (test.time_s - test.time_s[0]) / max(test.duration_s, 1e-300)
    progress = travel / max(travel[-1], 1e-300) + elapsed
    picks = np.searchsorted(progress, np.linspace(0.0, progress[-1], count))
    turns = [find_peaks(sign * test.displacement_m, prominence=0.05 * span)[0]
             for sign in (1.0, -1.0)]
    return np.unique(np.concatenate([picks.clip(0, n - 1), *turns, [0, n - 1]]))


def _subset(test: MechanicalTest, rows: np.ndarray) -> MechanicalTest:
    return replace(test, time_s=test.time_s[rows], displacement_m=test.displacement_m[rows],
                   force_N=test.force_N[rows])


Start = tuple[tuple[str, ...], np.ndarray] | None


@dataclass(frozen=True, eq=False)
class _Problem:
    """A set prepared for fits: the lattice, and the tests thinned for fitting."""

    specimen: Specimen
    tests: tuple[MechanicalTest, ...]
    thinned: tuple[MechanicalTest, ...]
    lattice: SpecimenLattice

    def unit_forces(self, model: CandidateMaterial, shape: np.ndarray,
                    tests: tuple[MechanicalTest, ...]) -> list[np.ndarray] | None:
        """Each test's force at modulus ``_REFERENCE_PA``, N; None when the lattice cannot give
        the material or a run has no equilibrium."""
        material = model.material(shape, _REFERENCE_PA, self.specimen.density_kg_m3)
        try:
            return [simulate_test(t, self.specimen, material, self.lattice).force_N
                    for t in tests]
        except (DivergenceError, MaterialError):
            return None


def _scale_and_offset(unit: np.ndarray, measured: np.ndarray,
                      with_offset: bool) -> tuple[float, float]:
    """Least-squares E / reference and offset (N) for ``measured ~ scale * unit + offset``."""
    columns = [unit, np.ones_like(unit)] if with_offset else [unit]
    solution, *_ = np.linalg.lstsq(np.stack(columns, axis=1), measured, rcond=None)
    scale = max(float(solution[0]), 1e-9)
    return scale, float(solution[1]) if with_offset else 0.0


def _fit(problem: _Problem, model: CandidateMaterial, tests: list[int], start: np.ndarray,
         max_evaluations: int) -> tuple[np.ndarray, float, float, float, int]:
    """Fit ``model`` to ``tests`` (indices, thinned samples): shape, E (Pa), offset (N),
    residual sum of squares and sample count."""
    chosen = tuple(problem.thinned[i] for i in tests)
    measured = np.concatenate([t.force_N for t in chosen])

    def solve(shape: np.ndarray) -> tuple[np.ndarray, float, float]:
        units = problem.unit_forces(model, shape, chosen)
        if units is None:
            return np.full(len(measured), _FAILED), 1.0, 0.0
        unit = np.concatenate(units)
        scale, offset = _scale_and_offset(unit, measured, model.has_offset)
        return scale * unit + offset - measured, scale, offset

    if len(start):
        lower, upper = model.bounds
        result = least_squares(lambda s: solve(s)[0], np.clip(start, lower, upper),
                               bounds=(lower, upper), x_scale="jac", diff_step=1e-3,
                               max_nfev=max_evaluations)
        shape = result.x
    else:
        shape = start
    residual, scale, offset = solve(shape)
    return shape, scale * _REFERENCE_PA, offset, float(residual @ residual), len(measured)


def _predict(problem: _Problem, model: CandidateMaterial, shape: np.ndarray, modulus_pa: float,
             offset_n: float, test: MechanicalTest) -> np.ndarray:
    """Force of ``test`` at every sample, N (a failed run predicts zero force)."""
    units = problem.unit_forces(model, shape, (test,))
    unit = np.zeros(len(test.force_N)) if units is None else units[0]
    return unit * modulus_pa / _REFERENCE_PA + offset_n


def fit_model(problem: _Problem, models: list[CandidateMaterial], params: DiagnosisParams,
              start: Start = None) -> ModelFit:
    """Fit each of ``models`` (variants of one candidate) to every test and keep the best:
    between stiffening laws, the lowest residual; between variants with other parameters, the
    lowest held-out error (module docstring)."""
    everything = list(range(len(problem.tests)))
    best: dict[tuple[str, ...], tuple] = {}
    for model in models:
        fit = (model, *_fit(problem, model, everything, _start(start, model),
                            params.max_evaluations))
        kind = tuple(n for n in model.parameter_names if "stiffening_" not in n)
        if kind not in best or fit[4] < best[kind][4]:
            best[kind] = fit
    return min((_hold_out(problem, *fit, params) for fit in best.values()),
               key=lambda fit: fit.heldout_rmse_n)


def _hold_out(problem: _Problem, model: CandidateMaterial, shape: np.ndarray, modulus: float,
              offset: float, rss: float, count: int, params: DiagnosisParams) -> ModelFit:
    """The fit of ``model`` on every test, and each test predicted by a refit without it."""
    everything = list(range(len(problem.tests)))
    fitted = tuple(_predict(problem, model, shape, modulus, offset, t) for t in problem.tests)
    heldout = []
    for left_out, test in enumerate(problem.tests):
        others = [i for i in everything if i != left_out]
        fold = _fit(problem, model, others, shape, params.fold_evaluations)
        heldout.append(_predict(problem, model, fold[0], fold[1], fold[2], test))
    residual = np.concatenate([h - t.force_N for h, t in zip(heldout, problem.tests,
                                                               strict=True)])
    parameters = len(shape) + 1 + int(model.has_offset)
    return ModelFit(
        model=model,
        shape=shape,
        modulus_pa=modulus,
        offset_n=offset,
        material=model.material(shape, modulus, problem.specimen.density_kg_m3),
        rmse_n=math.sqrt(rss / count),
        heldout_rmse_n=float(np.sqrt(np.mean(residual**2))),
        bic=count * math.log(max(rss / count, 1e-300)) + parameters * math.log(count),
        fitted_force_n=fitted,
        heldout_force_n=tuple(heldout),
    )


def _start(previous: Start, model: CandidateMaterial) -> np.ndarray:
    """A start for ``model`` from the (names, values) of a fit with one cause fewer: its values
    where the names match, ``model.initial`` elsewhere (everywhere when None)."""
    if previous is None:
        return model.initial
    names, values = previous
    start = model.initial.copy()
    for i, name in enumerate(model.parameter_names):
        if name in names:
            start[i] = values[names.index(name)]
    return start


def _variants(causes: tuple[str, ...], times: tuple[float, ...],
              stretch_range: tuple[float, float]) -> list[CandidateMaterial]:
    """The models for ``causes``: both stiffening laws when stiffening is among them, Eq. 10
    with and without its oblique factor when anisotropy is, one compression factor or two when
    the asymmetry is."""
    laws = ("exponential", "polynomial") if "strain_stiffening" in causes else ("exponential",)
    obliques = (False, True) if "anisotropy" in causes else (False,)
    apart = (False, True) if "tension_compression_asymmetry" in causes else (False,)
    return [CandidateMaterial(causes, law, times, stretch_range, oblique, split)
            for law in laws for oblique in obliques for split in apart]


def _relaxation_times_s(measurements: MeasurementSet) -> tuple[float, ...]:
    """Relaxation times spanning the tests: from a few sample intervals to the longest test."""
    shortest = min(float(np.median(np.diff(t.time_s))) for t in measurements.tests
                   if len(t.time_s) > 1)
    longest = max(t.duration_s for t in measurements.tests)
    low = max(3.0 * shortest, 1e-3)
    high = max(longest, 2.0 * low)
    return tuple(np.geomspace(low, high, _RELAXATION_TERMS).tolist())


def _stretch_range(measurements: MeasurementSet) -> tuple[float, float]:
    """The set's stretches, widened by 10% of their span and to contain 1."""
    strains = np.concatenate([t.strain(measurements.specimen) for t in measurements.tests])
    margin = 0.1 * max(float(np.ptp(strains)), 0.01)
    return (max(1.0 + min(float(strains.min()), 0.0) - margin, 0.05),
            1.0 + max(float(strains.max()), 0.0) + margin)


def _improved_fraction(fit: ModelFit, previous: ModelFit,
                       tests: tuple[MechanicalTest, ...]) -> float:
    """Fraction of the tests whose held-out RMSE ``fit`` lowers below ``previous``'s."""
    lower = [np.mean((new - test.force_N) ** 2) < np.mean((old - test.force_N) ** 2)
             for new, old, test in zip(fit.heldout_force_n, previous.heldout_force_n, tests,
                                       strict=True)]
    return float(np.mean(lower))


def _structure(fit: ModelFit, tests: tuple[MechanicalTest, ...]) -> float:
    """Lag-one autocorrelation of the held-out residuals, pooled over tests."""
    products, squares = 0.0, 0.0
    for predicted, test in zip(fit.heldout_force_n, tests, strict=True):
        residual = predicted - test.force_N
        residual = residual - residual.mean()
        products += float(residual[1:] @ residual[:-1])
        squares += float(residual @ residual)
    return products / max(squares, 1e-300)


def _task(args: tuple) -> ModelFit:
    return fit_model(*args)


def diagnose(measurements: MeasurementSet, params: DiagnosisParams | None = None) -> Diagnosis:
    """Diagnose ``measurements`` (module docstring: its usage; minutes on a ten-test set)."""
    params = DiagnosisParams() if params is None else params
    problem = _Problem(
        specimen=measurements.specimen,
        tests=measurements.tests,
        thinned=tuple(_subset(t, fit_samples(t, params.fit_samples))
                      for t in measurements.tests),
        lattice=SpecimenLattice.of(measurements.specimen),
    )
    times = _relaxation_times_s(measurements)
    stretch = _stretch_range(measurements)
    noise = noise_n(measurements)
    # Spawned, not forked: a fork of a process whose numba (and MuJoCo, in the CLI) has
    # started threads can deadlock. The workers load the compiled spring law from numba's
    # on-disk cache rather than compiling it again.
    pool = (ProcessPoolExecutor(params.workers, mp_context=get_context("spawn"))
            if params.workers > 1 else nullcontext())
    with pool:

        def fit_all(sets: list[tuple[str, ...]], start: Start) -> list[ModelFit]:
            jobs = [(problem, _variants(causes, times, stretch), params, start)
                    for causes in sets]
            if params.workers == 1:
                return [_task(job) for job in jobs]
            return list(pool.map(_task, jobs))

        baseline = fit_all([()], None)[0]
        candidates = fit_all([(cause,) for cause in CAUSES], None)
        current, steps, accepted = baseline, [], []
        trials = list(candidates)
        while trials:
            best = min(trials, key=lambda fit: fit.heldout_rmse_n)
            drop = current.heldout_rmse_n**2 - best.heldout_rmse_n**2
            if (drop <= params.min_variance_drop * noise**2 or best.bic >= current.bic
                    or best.heldout_rmse_n > (params.later_rmse_ratio if accepted else
                                              params.max_rmse_ratio) * current.heldout_rmse_n
                    or (accepted and _improved_fraction(best, current, measurements.tests)
                    < params.min_improved_fraction)):
                break
            added = next(c for c in best.model.causes if c not in current.model.causes)
            current = best
            accepted.append(added)
            steps.append(best)
            remaining = [c for c in CAUSES if c not in accepted]
            if not remaining:
                break
            start = (best.model.parameter_names, best.shape)
            trials = fit_all([(*accepted, cause) for cause in remaining], start)
    causes = tuple(accepted)
    if (current.heldout_rmse_n > params.unexplained_ratio * noise
            and _structure(current, measurements.tests) > params.structure_correlation):
        causes += (UNEXPLAINED,)
    return Diagnosis(measurements, noise, baseline, tuple(candidates), tuple(steps), current,
                     causes, params)
