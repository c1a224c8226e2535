"""Fitting one candidate material to a measurement set, and its error on held-out tests.

A fit searches the shape parameters of a
:class:`~cell.diagnosis.specimen.causes.candidate.CandidateMaterial`
with ``scipy.optimize.least_squares`` on up to ``fit_samples`` samples per test (picked evenly along
time and displacement, turning points kept) and solves for E and the load cell's offset in
closed form (the simulated force is linear in both). Each test is simulated by
:func:`~cell.diagnosis.specimen.solve.simulate_tests` with the muscles' own spring law.

Held-out errors are leave-one-test-out: each test is predicted, at every sample, by the model
refitted without it; where the tests name their specimens
(:mod:`cell.diagnosis.specimen.specimenids`), leave-one-specimen-out: without every test of
its specimen (the problem's ``folds``). The refit is one damped Gauss-Newton step from the
fit on every test, on the Jacobian that fit ended with (its rows of the other tests), then E
and the offset solved on the other tests again: the approximate leave-one-out of
M-estimation, a refit's cost of one simulation instead of dozens. A step that fits the other
tests worse than the fit it started from is not taken (a refit never ends worse than its
start), so that a parameter the other tests hardly set stays where the full fit put it.

The confidence intervals of the shape parameters come from the same Jacobian:
``s**2 (J^T J)^-1`` with ``s**2`` the residual variance, 95 % for a normal error.

Example:
    >>> from cell.measure.specimens import load_measurement_set
    >>> data = load_measurement_set("assets/measured/beef_round_example")
    >>> len(fit_samples(data.test("c00"), 32))
    32
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from cell.diagnosis.engine.determined import NOT_PREDICTED, determined, determined_each
from cell.diagnosis.engine.statistics import bic, half_widths_95
from cell.diagnosis.specimen.causes import CandidateMaterial
from cell.diagnosis.specimen.planeseries import PlaneSeries, Series, series_forces
from cell.diagnosis.specimen.solve import SpecimenLattice
from cell.errors import DivergenceError, MaterialError
from cell.measure.shearbiaxial import BiaxialTest, ShearTest
from cell.measure.specimens import MechanicalTest, Specimen
from cell.tissue.material import MassSpringMaterial

#: Modulus of the unit-modulus runs that E scales, Pa.
REFERENCE_PA = 1.0e4
# Residual of a fit whose material has no equilibrium somewhere: far worse than any real fit.
FAILED = 1.0e3
# Relative tolerances of a fit: far below the noise of any measured force, and a tenth of
# the evaluations least_squares spends reaching its default 1e-8 on a flat valley.
_TOLERANCE = 1e-5
# Damping of the held-out Gauss-Newton step, relative to the diagonal of the full fit's J^T J.
_STEP_DAMPING = 1e-2


def fit_samples(test: MechanicalTest | ShearTest | BiaxialTest, count: int) -> np.ndarray:
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
    elapsed = test.time_s - test.time_s[0]
    elapsed = elapsed / max(float(elapsed[-1]), 1e-300)
    progress = travel / max(travel[-1], 1e-300) + elapsed
    picks = np.searchsorted(progress, np.linspace(0.0, progress[-1], count))
    turns = [find_peaks(sign * test.displacement_m, prominence=0.05 * span)[0]
             for sign in (1.0, -1.0)]
    return np.unique(np.concatenate([picks.clip(0, n - 1), *turns, [0, n - 1]]))


def _thinned(test: Series, count: int) -> Series:
    """``test`` at its :func:`fit_samples`."""
    if isinstance(test, PlaneSeries):
        return test.subset(fit_samples(test.test, count))
    rows = fit_samples(test, count)
    return replace(test, time_s=test.time_s[rows], displacement_m=test.displacement_m[rows],
                   force_n=test.force_n[rows])


@dataclass(frozen=True, eq=False)
class Problem:
    """A set prepared for fits: the lattice, and the tests thinned for fitting.

    Attributes:
        specimen: the set's specimen.
        tests: its tests, every sample (uniaxial, then shear and biaxial ones as
            :class:`~cell.diagnosis.specimen.planeseries.PlaneSeries`).
        thinned: the same tests, ``fit_samples`` of them each.
        lattice: the specimen's spring lattice.
        folds: the tests held out together (indices; each test alone when empty).
    """

    specimen: Specimen
    tests: tuple[Series, ...]
    thinned: tuple[Series, ...]
    lattice: SpecimenLattice
    folds: tuple[tuple[int, ...], ...] = ()

    @classmethod
    def of(cls, specimen: Specimen, tests: tuple[Series, ...], samples: int,
           folds: list[list[int]] | None = None) -> Problem:
        """The problem of ``tests``, thinned to about ``samples`` samples each, held out in
        ``folds`` (each test alone when None or empty)."""
        return cls(specimen, tests, tuple(_thinned(t, samples) for t in tests),
                   SpecimenLattice.of(specimen), tuple(tuple(f) for f in folds or ()))

    def fold_of(self, test: int) -> list[int]:
        """The tests held out with ``test`` (itself included)."""
        return next((list(f) for f in self.folds if test in f), [test])

    def unit_forces(self, model: CandidateMaterial, shape: np.ndarray,
                    tests: tuple[Series, ...]) -> list[np.ndarray] | None:
        """Each test's force at modulus ``REFERENCE_PA``, N; None when the lattice cannot give
        the material or a run has no equilibrium."""
        try:
            material = model.material(shape, REFERENCE_PA, self.specimen.density_kg_m3)
            return series_forces(tests, self.specimen, material, self.lattice)
        except (DivergenceError, MaterialError):
            return None


def scale_and_offset(unit: np.ndarray, measured: np.ndarray,
                     with_offset: bool) -> tuple[float, float]:
    """Least-squares E / reference and offset (N) for ``measured ~ scale * unit + offset``."""
    columns = [unit, np.ones_like(unit)] if with_offset else [unit]
    solution, *_ = np.linalg.lstsq(np.stack(columns, axis=1), measured, rcond=None)
    scale = max(float(solution[0]), 1e-9)
    return scale, float(solution[1]) if with_offset else 0.0


@dataclass(frozen=True, eq=False, kw_only=True)
class HeldOutScores:
    """What a uniaxial and a cut fit share: their errors and forces (keyword arguments, after
    the fitted model's own fields), and methods reading the ``model`` and ``params`` of the
    dataclass that takes it in.

    Attributes:
        rmse_n: RMSE on the fitted samples, N.
        heldout_rmse_n: RMSE of leave-one-test-out predictions over every sample, N.
        bic: Bayesian information criterion of the fit.
        fitted_force_n: per test, the fitted model's force at every sample, N.
        heldout_force_n: per test, the force predicted by the fit without that test, N.
        failed_test: the first test the fitted model could not run (None when all ran).
    """

    rmse_n: float
    heldout_rmse_n: float
    bic: float
    fitted_force_n: tuple[np.ndarray, ...]
    heldout_force_n: tuple[np.ndarray, ...]
    failed_test: str | None = None

    def heldout_mse_per_test(self, tests: tuple[Any, ...]) -> np.ndarray:
        """Each test's held-out mean square error, N^2 (``tests``: the fitted ones, each with
        its measured ``force_n``: :class:`MechanicalTest` or
        :class:`~cell.diagnosis.cut.fitting.CutSeries`)."""
        return np.array([np.mean((h - t.force_n) ** 2)
                         for h, t in zip(self.heldout_force_n, tests, strict=True)])

    def to_json(self) -> dict[str, Any]:
        """The contract's ``baseline`` / ``extended`` entry (plus ``bic``)."""
        return {"model": self.model.name, "params": determined_each(self.params),
                **self.scores_json()}

    def scores_json(self) -> dict[str, Any]:
        """The held-out RMSE and the BIC, each ``null`` with its reason where the fit does not
        determine it (:mod:`cell.diagnosis.engine.determined`)."""
        return {**determined("heldout_rmse_N", self.heldout_rmse_n, NOT_PREDICTED),
                **determined("bic", self.bic, NOT_PREDICTED)}


@dataclass(frozen=True, eq=False)
class ModelFit(HeldOutScores):
    """A material model fitted to a set, and its error on held-out tests.

    Attributes:
        model: the model (causes, stiffening law).
        shape: its shape parameters.
        ci95: (p, 2) their 95 % confidence intervals (NaN where the data do not set one).
        modulus_pa: fitted small-strain modulus E (geometric mean of El and Et), Pa.
        offset_n: fitted load-cell offset, N (0 without ``force_offset``).
        material: the fitted material.

    Its errors and forces: :class:`HeldOutScores`.
    """

    model: CandidateMaterial
    shape: np.ndarray
    ci95: np.ndarray
    modulus_pa: float
    offset_n: float
    material: MassSpringMaterial

    @property
    def params(self) -> dict[str, float]:
        """Fitted parameters in SI units."""
        return self.model.reported(self.shape, self.modulus_pa, self.offset_n)

    @property
    def shape_ci95(self) -> np.ndarray:
        """The name of :attr:`ci95` in 0.1.0 (a cut fit's is ``ci95`` too), for one release."""
        return self.ci95


def _residual_function(problem: Problem, model: CandidateMaterial, tests: list[int]):
    """shape -> (residual on the thinned samples of ``tests``, scale, offset)."""
    chosen = tuple(problem.thinned[i] for i in tests)
    measured = np.concatenate([t.force_n for t in chosen])

    def solve(shape: np.ndarray) -> tuple[np.ndarray, float, float]:
        units = problem.unit_forces(model, shape, chosen)
        if units is None:
            return np.full(len(measured), FAILED), 1.0, 0.0
        unit = np.concatenate(units)
        scale, offset = scale_and_offset(unit, measured, model.has_offset)
        return scale * unit + offset - measured, scale, offset

    return solve


def _predict(problem: Problem, model: CandidateMaterial, shape: np.ndarray, scale: float,
             offset_n: float, tests: tuple[MechanicalTest, ...]) -> list[np.ndarray] | None:
    """Force of ``tests`` at every sample, N; None when the material cannot run them."""
    units = problem.unit_forces(model, shape, tests)
    return None if units is None else [u * scale + offset_n for u in units]


def _failed_test(problem: Problem, model: CandidateMaterial, shape: np.ndarray) -> str | None:
    for test in problem.tests:
        if problem.unit_forces(model, shape, (test,)) is None:
            return test.test_id
    return None


def fit(problem: Problem, model: CandidateMaterial, start: np.ndarray,
        max_evaluations: int) -> ModelFit:
    """Fit ``model`` to every test from ``start`` and predict each test held out (module
    docstring)."""
    everything = list(range(len(problem.tests)))
    solve = _residual_function(problem, model, everything)
    lower, upper = model.bounds
    if len(start):
        result = least_squares(lambda s: solve(s)[0], np.clip(start, lower, upper),
                               bounds=(lower, upper), x_scale="jac", diff_step=1e-3,
                               ftol=_TOLERANCE, xtol=_TOLERANCE, max_nfev=max_evaluations)
        shape, jacobian = result.x, result.jac
    else:
        shape, jacobian = start, np.zeros((0, 0))
    residual, scale, offset = solve(shape)
    count = len(residual)
    rss = float(residual @ residual)
    fitted = _predict(problem, model, shape, scale, offset, problem.tests)
    failed = None
    if fitted is None:
        failed = _failed_test(problem, model, shape)
        fitted = [np.zeros(len(t.force_n)) for t in problem.tests]
    heldout = _held_out(problem, model, shape, residual, jacobian, (lower, upper))
    parameters = len(shape) + 1 + int(model.has_offset)
    return ModelFit(
        model=model, shape=shape, ci95=_ci95(jacobian, rss, count, shape),
        modulus_pa=scale * REFERENCE_PA, offset_n=offset,
        material=model.material(shape, scale * REFERENCE_PA, problem.specimen.density_kg_m3),
        rmse_n=math.sqrt(rss / count),
        heldout_rmse_n=float(np.sqrt(np.mean(np.concatenate(
            [(h - t.force_n) ** 2 for h, t in zip(heldout, problem.tests, strict=True)])))),
        bic=bic(rss, count, parameters),
        fitted_force_n=tuple(fitted), heldout_force_n=tuple(heldout), failed_test=failed)


def _held_out(problem: Problem, model: CandidateMaterial, shape: np.ndarray,
              residual: np.ndarray, jacobian: np.ndarray,
              bounds: tuple[np.ndarray, np.ndarray]) -> list[np.ndarray]:
    """Each test predicted at every sample by the one-step refit without it (module
    docstring); a refit whose material cannot run predicts zero force."""

    def predict(left_out: int, trial: np.ndarray, worst_rss: float) -> np.ndarray | None:
        fold = problem.fold_of(left_out)
        others = [i for i in range(len(problem.tests)) if i not in fold]
        if not others:
            return None
        measured = np.concatenate([problem.thinned[i].force_n for i in others])
        chosen = (*(problem.thinned[i] for i in others), problem.tests[left_out])
        return _fold(problem, model, trial, chosen, measured, worst_rss)

    return one_step_held_out([len(t.force_n) for t in problem.thinned],
                             [len(t.force_n) for t in problem.tests], shape, residual, jacobian,
                             bounds, predict, problem.fold_of)


def one_step_held_out(sizes: list[int], lengths: list[int], shape: np.ndarray,
                      residual: np.ndarray, jacobian: np.ndarray,
                      bounds: tuple[np.ndarray, np.ndarray],
                      predict: Callable[[int, np.ndarray, float], np.ndarray | None],
                      fold_of: Callable[[int], list[int]] = lambda k: [k]
                      ) -> list[np.ndarray]:
    """The leave-one-test-out scheme of the module docstring, for any model whose fit ended
    at ``shape`` with ``residual`` and ``jacobian`` over tests of ``sizes`` fitted samples
    each (``lengths`` samples in all): test k is ``predict(k, trial, worst_rss)``, its force
    at every sample with the closed-form parameters solved on the other tests at the shape
    ``trial`` (None when that fits them worse than ``worst_rss``, or cannot run), first at
    the damped Gauss-Newton step without test k's rows, then at ``shape``; zero force when
    neither gives one; ``fold_of(k)`` are the tests whose rows the step leaves out with test k
    (test k alone by default). The cut tests' fits use it too
    (:mod:`cell.diagnosis.cut.fitting`)."""
    rows = np.split(np.arange(sum(sizes)), np.cumsum(sizes)[:-1])
    damping = _STEP_DAMPING * (np.diag(jacobian.T @ jacobian) + 1e-300) if len(shape) else None
    heldout = []
    for left_out in range(len(sizes)):
        fold = fold_of(left_out)
        keep = np.concatenate([rows[i] for i in range(len(sizes)) if i not in fold]
                              or [np.zeros(0, dtype=int)])
        prediction = None
        if len(shape):
            j, r = jacobian[keep], residual[keep]
            step = np.linalg.solve(j.T @ j + np.diag(damping), -j.T @ r)
            prediction = predict(left_out, np.clip(shape + step, *bounds), float(r @ r))
        if prediction is None:
            prediction = predict(left_out, shape, math.inf)
        heldout.append(np.zeros(lengths[left_out]) if prediction is None else prediction)
    return heldout


def _fold(problem: Problem, model: CandidateMaterial, shape: np.ndarray,
          tests: tuple[MechanicalTest, ...], measured: np.ndarray,
          worst_rss: float) -> np.ndarray | None:
    """The last of ``tests`` predicted with ``shape``, E and the offset solved on the others
    (``measured``); None when the material cannot run them or fits the others no better than
    ``worst_rss``."""
    units = problem.unit_forces(model, shape, tests)
    if units is None:
        return None
    others = np.concatenate(units[:-1])
    scale, offset = scale_and_offset(others, measured, model.has_offset)
    misfit = scale * others + offset - measured
    if float(misfit @ misfit) > worst_rss:
        return None
    return units[-1] * scale + offset


def _ci95(jacobian: np.ndarray, rss: float, count: int, shape: np.ndarray) -> np.ndarray:
    """95 % intervals of the shape parameters from the fit's Jacobian (module docstring)."""
    if not len(shape):
        return np.zeros((0, 2))
    half = half_widths_95(jacobian, rss / max(count - len(shape), 1))
    return np.stack([shape - half, shape + half], axis=1)
