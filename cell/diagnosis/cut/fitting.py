"""Fitting one candidate cutting model to a set's cut tests, and its error on held-out tests.

The scheme of the uniaxial fits (:mod:`cell.diagnosis.specimen.fitting`) on the reduced model of a
cut (:mod:`cell.diagnosis.cut.reduced`): ``scipy.optimize.least_squares`` searches the shape
parameters of a :class:`~cell.diagnosis.cut.causes.candidate.CutCandidate` on thinned samples of
every
test, the linear ones (toughness per layer, the faces' shear stress, the sensor's offset) are
solved in closed form at each step (bounded: toughness and friction not negative); held-out
errors are leave-one-test-out, each test predicted at every sample by one damped Gauss-Newton
step from the full fit on the other tests' rows of its Jacobian, the linear parameters solved
on the other tests again, the step not taken when it fits them worse.

A test's force is one series, channel after channel
(:func:`~cell.diagnosis.cut.causes.candidate.flat`):
:class:`CutSeries` carries it under the names that the acceptance of a cause reads
(:mod:`cell.diagnosis.engine.acceptance`), so both kinds of test are judged by the same rules.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy.optimize import least_squares, lsq_linear

from cell.diagnosis.cut.causes import CutCandidate, flat, linear_columns
from cell.diagnosis.cut.reduced import CutKinematics
from cell.diagnosis.engine.determined import estimates_json
from cell.diagnosis.engine.statistics import bic, half_widths_95
from cell.diagnosis.specimen.fitting import HeldOutScores, one_step_held_out
from cell.measure.cuts import Blade, Block, CutTest
from cell.tissue.cutmodel import CuttingParams, edge_force

# Relative tolerance of a fit: as the uniaxial fits'.
_TOLERANCE = 1e-5


@dataclass(frozen=True, eq=False)
class CutSeries:
    """One cut test as a single force series for the rules that judge a cause.

    Attributes:
        test_id: the test's name.
        mode: ``"cut"``.
        force_n: the measured force, channel after channel, N.
        rest_samples: indices into ``force_n`` of the samples with the edge above the top
            face, where no cutting model puts a force on the blade (every channel).
        slides: whether the edge slides along itself in the material
            (:attr:`~cell.diagnosis.cut.reduced.CutKinematics.slides`).
    """

    test_id: str
    mode: str
    force_n: np.ndarray
    rest_samples: np.ndarray
    slides: bool = True

    @classmethod
    def of(cls, test: CutTest, block: Block, slides: bool = True) -> CutSeries:
        """The series of ``test`` cut in ``block``, its edge sliding along itself or not."""
        above = np.flatnonzero(test.depth_m(block) < 0.0)
        samples = len(test.time_s)
        return cls(test.test_id, "cut", flat(test.force_n),
                   np.concatenate([above + k * samples for k in range(3)]), slides)


@dataclass(frozen=True, eq=False)
class CutProblem:
    """A set's cut tests prepared for fits: their kinematics, every sample and thinned.

    Attributes:
        block: the block.
        blade: the blade.
        tests: the cut tests as force series (:class:`CutSeries`).
        kinematics: per test, every sample.
        thinned: per test, about ``samples`` of them.
        thinned_force_n: per test, the thinned measured force as one series, N.
    """

    block: Block
    blade: Blade
    tests: tuple[CutSeries, ...]
    kinematics: tuple[CutKinematics, ...]
    thinned: tuple[CutKinematics, ...]
    thinned_force_n: tuple[np.ndarray, ...]

    @classmethod
    def of(cls, block: Block, blade: Blade, tests: tuple[CutTest, ...],
           samples: int) -> CutProblem:
        """The problem of ``tests``, thinned to about ``samples`` samples each (evenly in
        time)."""
        kinematics = tuple(CutKinematics.of(t, block, blade) for t in tests)
        rows = [np.unique(np.searchsorted(t.time_s, np.linspace(
            t.time_s[0], t.time_s[-1], samples)).clip(0, len(t.time_s) - 1)) for t in tests]
        return cls(block, blade, tuple(CutSeries.of(t, block, k.slides)
                                       for t, k in zip(tests, kinematics, strict=True)),
                   kinematics,
                   tuple(k.rows(r) for k, r in zip(kinematics, rows, strict=True)),
                   tuple(flat(t.force_n[r]) for t, r in zip(tests, rows, strict=True)))

    def reference_speed_m_s(self) -> float:
        """The median speed of the edges while they cut: the rate factor's v_ref."""
        speeds = np.concatenate([np.linalg.norm(k.push_m_s + k.slice_m_s, axis=1)[
            k.engaged_length_m > 0] for k in self.kinematics])
        return float(np.median(speeds)) if len(speeds) else 0.01


def solve_linear(columns: np.ndarray, measured: np.ndarray,
                 model: CutCandidate) -> np.ndarray:
    """The linear parameters of ``model`` for ``measured ~ columns @ linear``: toughness and
    friction not negative, the offset free; zero where no sample depends on one (a layer no
    edge reached, in a fit that leaves out the one test that reached it)."""
    lower = np.array([-np.inf if n.startswith("offset_") else 0.0 for n in model.linear_names])
    scale = np.abs(columns).max(axis=0)
    # A column of zeros leaves its parameter free: the solver's value there is round-off,
    # and dividing it by the column's scale would blow it up.
    used = scale > 0.0
    linear = np.zeros(columns.shape[1])
    if used.any():
        result = lsq_linear(columns[:, used] / scale[used], measured,
                            bounds=(lower[used], np.inf), method="bvls")
        linear[used] = result.x / scale[used]
    return linear


@dataclass(frozen=True, eq=False)
class CutFit(HeldOutScores):
    """A cutting model fitted to a set's cut tests, and its error on held-out tests.

    Attributes mirror :class:`~cell.diagnosis.specimen.fitting.ModelFit`: ``model``, ``shape``,
    ``linear`` (the closed-form parameters), ``cutting`` (the fitted cutting model), and
    from :class:`~cell.diagnosis.specimen.fitting.HeldOutScores` ``rmse_n`` (on the fitted samples),
    ``heldout_rmse_n`` (leave-one-test-out, every sample), ``bic``, ``fitted_force_n`` and
    ``heldout_force_n`` (per test, one series each).
    """

    model: CutCandidate
    shape: np.ndarray
    linear: np.ndarray
    cutting: CuttingParams
    ci95: np.ndarray

    @property
    def fitted(self) -> dict[str, tuple[float, float, float]]:
        """Every fitted parameter in the fit's own names (the shape parameters, then the
        linear ones: :attr:`CutCandidate.parameter_names`, :attr:`CutCandidate.linear_names`)
        with its 95 % interval: (value, low, high), NaN where the data do not bound it."""
        names = (*self.model.parameter_names, *self.model.linear_names)
        values = np.concatenate([self.shape, self.linear])
        return {n: (float(v), float(lo), float(hi))
                for n, v, (lo, hi) in zip(names, values, self.ci95, strict=True)}

    def to_json(self) -> dict[str, Any]:
        """The contract's entry, plus ``fitted``: each fitted parameter with its 95 %
        interval (:attr:`fitted`)."""
        return {**super().to_json(), "fitted": estimates_json(self.fitted)}

    @property
    def params(self) -> dict[str, float]:
        """Fitted parameters in SI units."""
        return self.model.reported(self.shape, self.linear)

    @property
    def offset_n(self) -> np.ndarray:
        """The sensor's fitted offset, N (zero without ``blade_force_offset``)."""
        solved = dict(zip(self.model.linear_names, self.linear, strict=True))
        return np.array([solved.get(f"offset_{a}_n", 0.0) for a in "xyz"])


def _columns(problem: CutProblem, model: CutCandidate, shape: np.ndarray,
             which: list[int], thinned: bool = True) -> list[np.ndarray]:
    kinematics = problem.thinned if thinned else problem.kinematics
    return [linear_columns(model, shape, kinematics[i]) for i in which]


def best_layer_depth(problem: CutProblem, model: CutCandidate, shape: np.ndarray
                     ) -> np.ndarray:
    """``shape`` with its layer boundary (``layer_depth_0_m``, of a two-layer model) at the
    depth where the misfit over every sample of every test is least, the other shape
    parameters as they are and the linear ones solved there (without their bounds).

    The force changes with the boundary only where it passes a depth that the edge cut fresh
    material at, so every depth halfway between two neighbouring such depths is tried: the
    edge's column of the layer above the boundary is the sum of the strips cut above it,
    and the normal equations of each try are sums over the samples of that column's
    products, which a cumulative sum over the tried depths gives all at once."""
    index = model.parameter_names.index("layer_depth_0_m")
    low, high = (float(b[index]) for b in model.bounds)
    base = replace(model, causes=tuple(c for c in model.causes if c != "layered_toughness"))
    base_shape = np.delete(shape, index)
    unit = model.unit_edge(shape)[0]
    parts = [_layer_products(unit, base, base_shape, k, np.asarray(t.force_n))
             for k, t in zip(problem.kinematics, problem.tests, strict=True)]
    depths = np.unique(np.concatenate([p.depth for p in parts]))
    tried = 0.5 * (depths[1:] + depths[:-1])
    tried = tried[(tried > low) & (tried < high)]
    if not len(tried):
        return shape
    columns = parts[0].columns.shape[1]
    gram = np.zeros((len(tried), columns + 1, columns + 1))
    right = np.zeros((len(tried), columns + 1))
    for part in parts:
        gram[:, :columns, :columns] += part.columns.T @ part.columns
        right[:, :columns] += part.columns.T @ part.measured
        upper = part.upper_weights(tried)
        gram[:, -1, -1] += (upper**2).T @ part.unit_sq
        cross = upper.T @ part.unit_dot_columns
        gram[:, -1, :columns] += cross
        gram[:, :columns, -1] += cross
        right[:, -1] += upper.T @ part.unit_dot_measured
    scale = np.sqrt(np.maximum(np.einsum("mii->mi", gram), 1e-300))
    scaled = gram / scale[:, :, None] / scale[:, None, :] + 1e-10 * np.eye(columns + 1)
    solved = np.linalg.solve(scaled, (right / scale)[..., None])[..., 0]
    explained = np.einsum("mi,mi->m", solved, right / scale)
    best = shape.copy()
    best[index] = tried[int(np.argmax(explained))]
    return best


@dataclass(frozen=True, eq=False)
class _LayerProducts:
    """One test's share of :func:`best_layer_depth`'s normal equations, over its samples
    that cut fresh material (its rows); u is the edge's force per metre of engaged edge.

    Attributes:
        columns: (3 n, k) the model's linear columns without layers, every sample.
        measured: (3 n,) the measured force, N.
        unit_sq: (rows,) u squared.
        unit_dot_columns: (rows, k) u with each column at the row's sample.
        unit_dot_measured: (rows,) u with the measured force at the row's sample.
        row: (pairs,) the row of each fresh strip.
        depth: (pairs,) the strip's depth, m.
        weight: (pairs,) the strip's width times the indentation ramp there, m.
    """

    columns: np.ndarray
    measured: np.ndarray
    unit_sq: np.ndarray
    unit_dot_columns: np.ndarray
    unit_dot_measured: np.ndarray
    row: np.ndarray
    depth: np.ndarray
    weight: np.ndarray

    def upper_weights(self, tried: np.ndarray) -> np.ndarray:
        """(rows, m) each row's engaged length above each tried depth (ramp-weighted)."""
        steps = np.zeros((len(self.unit_sq), len(tried) + 1))
        np.add.at(steps, (self.row, np.searchsorted(tried, self.depth, side="right")),
                  self.weight)
        return np.cumsum(steps, axis=1)[:, :-1]


def _layer_products(unit: CuttingParams, base: CutCandidate, base_shape: np.ndarray,
                    kinematics: CutKinematics, measured: np.ndarray) -> _LayerProducts:
    """The products of :class:`_LayerProducts` for one test."""
    n = len(kinematics.middle_depth_m)
    columns = linear_columns(base, base_shape, kinematics)
    weights = kinematics.strip_width_m * np.where(
        kinematics.fresh, unit.indentation_ramp(kinematics.depth_m), 0.0)
    rows = np.flatnonzero((weights > 0).any(axis=1))
    per_metre = edge_force(unit.uniform(), np.ones(n), kinematics.push_m_s,
                           kinematics.slice_m_s, kinematics.middle_depth_m)[rows]
    at_rows = np.stack([columns[rows + axis * n] for axis in range(3)], axis=1)
    seen = np.stack([measured[rows + axis * n] for axis in range(3)], axis=1)
    row, strip = np.nonzero(weights[rows] > 0)
    return _LayerProducts(columns, measured, np.einsum("ra,ra->r", per_metre, per_metre),
                          np.einsum("ra,rak->rk", per_metre, at_rows),
                          np.einsum("ra,ra->r", per_metre, seen), row,
                          kinematics.depth_m[rows][row, strip], weights[rows][row, strip])


def refine(problem: CutProblem, model: CutCandidate, start: np.ndarray,
           max_evaluations: int) -> tuple[np.ndarray, np.ndarray]:
    """The shape parameters of ``model`` that fit the thinned samples of every test best from
    ``start`` (the linear ones solved at each step), and the residuals' Jacobian there."""
    everything = list(range(len(problem.tests)))
    measured = np.concatenate(problem.thinned_force_n)
    if not len(start):
        return np.asarray(start, dtype=float), np.zeros((len(measured), 0))

    def residual(shape: np.ndarray) -> np.ndarray:
        columns = np.vstack(_columns(problem, model, shape, everything))
        return columns @ solve_linear(columns, measured, model) - measured

    lower, upper = model.bounds
    result = least_squares(residual, np.clip(start, lower, upper), bounds=(lower, upper),
                           x_scale="jac", diff_step=1e-3, ftol=_TOLERANCE, xtol=_TOLERANCE,
                           max_nfev=max_evaluations)
    return result.x, result.jac


def fit_cut(problem: CutProblem, model: CutCandidate, start: np.ndarray,
            max_evaluations: int) -> CutFit:
    """Fit ``model`` to every cut test from ``start`` and predict each test held out (module
    docstring)."""
    everything = list(range(len(problem.tests)))
    measured = np.concatenate(problem.thinned_force_n)
    shape, jacobian = refine(problem, model, start, max_evaluations)
    lower, upper = model.bounds
    columns = np.vstack(_columns(problem, model, shape, everything))
    linear = solve_linear(columns, measured, model)
    misfit = columns @ linear - measured
    rss, count = float(misfit @ misfit), len(misfit)
    fitted = [c @ linear for c in _columns(problem, model, shape, everything, thinned=False)]
    heldout = _held_out(problem, model, shape, misfit, jacobian, (lower, upper))
    errors = np.concatenate([h - t.force_n for h, t in zip(heldout, problem.tests,
                                                           strict=True)])
    parameters = len(shape) + len(linear)
    return CutFit(model, shape, linear, model.cutting(shape, linear),
                  _ci95(problem, model, shape, linear, rss, count),
                  rmse_n=math.sqrt(rss / count),
                  heldout_rmse_n=float(np.sqrt(np.mean(errors**2))),
                  bic=bic(rss, count, parameters),
                  fitted_force_n=tuple(fitted), heldout_force_n=tuple(heldout))


def _ci95(problem: CutProblem, model: CutCandidate, shape: np.ndarray, linear: np.ndarray,
          rss: float, count: int) -> np.ndarray:
    """(k, 2) 95 % intervals of the shape and linear parameters, from the Jacobian of the
    thinned samples' force in all of them (central differences in the shape parameters, over
    a fiftieth of their range for a layer's depth, which the force steps at, a thousandth
    for the others; the columns for the linear ones)."""
    everything = list(range(len(problem.tests)))
    lower, upper = model.bounds
    derivatives = []
    for i, name in enumerate(model.parameter_names):
        step = (upper[i] - lower[i]) * (0.02 if name.startswith("layer_depth_") else 1e-3)
        sides = [np.vstack(_columns(problem, model, np.where(
            np.arange(len(shape)) == i, np.clip(shape[i] + sign * step, lower[i], upper[i]),
            shape), everything)) @ linear for sign in (1.0, -1.0)]
        spread = min(shape[i] + step, upper[i]) - max(shape[i] - step, lower[i])
        derivatives.append((sides[0] - sides[1]) / max(spread, 1e-300))
    jacobian = np.column_stack([*derivatives, np.vstack(_columns(problem, model, shape,
                                                                  everything))])
    values = np.concatenate([shape, linear])
    half = half_widths_95(jacobian, rss / max(count - len(values), 1))
    return np.stack([values - half, values + half], axis=1)


def _held_out(problem: CutProblem, model: CutCandidate, shape: np.ndarray,
              misfit: np.ndarray, jacobian: np.ndarray,
              bounds: tuple[np.ndarray, np.ndarray]) -> list[np.ndarray]:
    """Each test predicted at every sample by the one-step refit without it (module
    docstring: the uniaxial fits' scheme,
    :func:`cell.diagnosis.specimen.fitting.one_step_held_out`)."""

    def predict(left_out: int, trial: np.ndarray, worst_rss: float) -> np.ndarray | None:
        others = [i for i in range(len(problem.tests)) if i != left_out]
        if not others:
            return None
        measured = np.concatenate([problem.thinned_force_n[i] for i in others])
        columns = np.vstack(_columns(problem, model, trial, others))
        linear = solve_linear(columns, measured, model)
        error = columns @ linear - measured
        if float(error @ error) > worst_rss:
            return None
        return _columns(problem, model, trial, [left_out], thinned=False)[0] @ linear

    return one_step_held_out([len(f) for f in problem.thinned_force_n],
                             [len(t.force_n) for t in problem.tests], shape, misfit, jacobian,
                             bounds, predict)
