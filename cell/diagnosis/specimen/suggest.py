"""The next test to run (``musclecell diagnose --suggest``): when other models explain a set
about as well as the diagnosis's, the candidate test whose outcome they predict most apart.

1. The rivals of the extended model (:func:`rivals`): every model the search fitted whose
   held-out mean square error is within ``min_variance_drop`` noise variances of the extended
   model's (the diagnosis could not tell them apart); and, per cause the extended model lacks,
   that model with the cause at a typical magnitude of muscle (:data:`TYPICAL`, both signs
   where it has one), E and the offset solved on the set again, when it fits the set within
   the same margin: a set that holds no compression cannot exclude an asymmetry, whatever the
   fit says of its size.
2. The candidate tests (:mod:`cell.diagnosis.specimen.nexttests`): ramps, ramp-and-holds and
   cycles in tension and compression, along, oblique and across the fibres, at the set's own strains
   and rates, each simulated with the extended model and every rival.
3. A test's score: per rival, the RMS over its samples of the predicted difference from the
   extended model in units of the spread one measurement has (the noise, and the specimen
   spread times the force where ``specimen_variability`` is named), capped at
   :data:`SuggestParams.cap` (a difference that far beyond the scatter is told apart for sure,
   and a larger one tells no more); summed over the rivals (ties to the larger uncapped sum).
   The best test is named with the rival it separates most and that difference, in newtons
   and in units of the scatter.

There is no suggestion when no rival explains the set as well (the set already tells its
candidates apart). Usage::

    diagnosis = diagnose(load_measurement_set("some-set"))
    suggestion = suggest(diagnosis)
    suggestion.test.description if suggestion.ambiguous else "nothing to tell apart"
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from cell.diagnosis.engine.determined import NOT_PREDICTED, determined
from cell.diagnosis.specimen.causes import CAUSES, EXCLUSIVE, CandidateMaterial
from cell.diagnosis.specimen.diagnosis import Diagnosis
from cell.diagnosis.specimen.fitting import REFERENCE_PA, ModelFit, Problem, scale_and_offset
from cell.diagnosis.specimen.nexttests import CandidateTest, candidate_tests
from cell.diagnosis.specimen.solve import SpecimenLattice, simulate_tests
from cell.errors import DiagnosisError, DivergenceError, MaterialError
from cell.measure.specimens import MechanicalTest, Specimen
from cell.tissue.material import MassSpringMaterial

#: Per cause, the shape parameters it takes at a typical magnitude of muscle, one entry per
#: sign the effect may have: fibres two to three times stiffer than the cross direction
#: (either way round), compression moduli half or twice those in tension, an exponential
#: stiffening with exponent 8, half the stress relaxing, yield at 3 % strain.
TYPICAL: dict[str, tuple[dict[str, float], ...]] = {
    "strain_stiffening": ({"stiffening_exponent": 8.0, "compression_stiffening_exponent": 8.0},),
    "anisotropy": ({"log_el_over_et": 1.0, "log_el_over_et_compressed": 1.0},
                   {"log_el_over_et": -1.0, "log_el_over_et_compressed": -1.0}),
    "viscoelasticity": ({"relaxed_fraction": 0.5},),
    "nonlinear_viscoelasticity": ({"relaxed_fraction_slope": 3.0},
                                  {"relaxed_fraction_slope": -3.0}),
    "tension_compression_asymmetry": ({"log_compression": 0.7}, {"log_compression": -0.7}),
    "plasticity": ({"yield_strain": 0.03, "hardening": 0.2},),
}


@dataclass(frozen=True)
class SuggestParams:
    """How a test is suggested.

    Attributes:
        max_fitted_rivals: at most this many fitted models are rivals (the closest).
        cap: a rival's score on a test is capped at this many units of the scatter.

    Raises:
        DiagnosisError: ``max_fitted_rivals`` < 1 or ``cap`` <= 0.

    Example:
        >>> SuggestParams().cap
        5.0
    """

    max_fitted_rivals: int = 6
    cap: float = 5.0

    def __post_init__(self) -> None:
        if self.max_fitted_rivals < 1 or not self.cap > 0.0:
            raise DiagnosisError(None, "suggest", f"max_fitted_rivals >= 1 and cap > 0, got "
                                 f"{self.max_fitted_rivals} and {self.cap}")


@dataclass(frozen=True, eq=False)
class Rival:
    """A model that explains the set about as well as the extended model.

    Attributes:
        name: the model's name (plus the cause set at a typical magnitude, for a probe).
        causes: its causes.
        material: its material.
        offset_n: its load-cell offset, N.
        rmse_n: its RMSE on the set's fitted samples, N.
        typical: the cause put in at a typical magnitude (None: a model the search fitted).
    """

    name: str
    causes: tuple[str, ...]
    material: MassSpringMaterial
    offset_n: float
    rmse_n: float
    typical: str | None = None

    def to_json(self) -> dict[str, Any]:
        """The rival as the suggestion's JSON lists it."""
        return {"model": self.name, "causes": list(self.causes),
                **determined("rmse_N", self.rmse_n, NOT_PREDICTED), "typical": self.typical}


@dataclass(frozen=True, eq=False)
class Suggestion:
    """What :func:`suggest` found.

    Attributes:
        ambiguous: whether any rival explains the set about as well as the extended model.
        rivals: those rivals.
        test: the test to run next (None when not ambiguous).
        rival: the rival the test separates most from the extended model (None likewise).
        difference_n: RMS of their predicted difference over the test's samples, N.
        scatter_n: the spread one measurement of that test has (noise and specimen spread,
            RMS over its samples), N.
        score: the test's score (module docstring, 3).
        ranking: the best candidate tests and their scores, best first.
        spread_sd: the specimen spread used (standard deviation of the log modulus factor).
    """

    ambiguous: bool
    rivals: tuple[Rival, ...]
    test: CandidateTest | None = None
    rival: Rival | None = None
    difference_n: float = 0.0
    scatter_n: float = 0.0
    score: float = 0.0
    ranking: tuple[tuple[CandidateTest, float], ...] = ()
    spread_sd: float = 0.0

    @property
    def over_scatter(self) -> float:
        """The predicted difference in units of the scatter (0 with no suggestion)."""
        return self.difference_n / self.scatter_n if self.scatter_n > 0 else 0.0

    def summary(self) -> str:
        """One line for people."""
        if self.test is None or self.rival is None:
            return "suggest: no other model explains the set as well; no test to add"
        return (f"suggest: {self.test.description}: the extended model and "
                f"{self.rival.name} differ there by {self.difference_n:.3g} N RMS, "
                f"{self.over_scatter:.1f} times the scatter "
                f"({len(self.rivals)} rival models)")

    def to_json(self) -> dict[str, Any]:
        """The ``suggestion`` entry of the diagnosis JSON."""
        return {
            "ambiguous": self.ambiguous,
            "rivals": [r.to_json() for r in self.rivals],
            "test": None if self.test is None else self.test.to_json(),
            "rival": None if self.rival is None else self.rival.name,
            **determined("predicted_difference_N", self.difference_n, NOT_PREDICTED),
            **determined("scatter_N", self.scatter_n, NOT_PREDICTED),
            **determined("predicted_difference_over_scatter", self.over_scatter, NOT_PREDICTED),
            **determined("score", self.score, NOT_PREDICTED),
            **determined("specimen_spread_sd", self.spread_sd),
            "ranking": [{**t.to_json(), **determined("score", s, NOT_PREDICTED)}
                        for t, s in self.ranking],
        }


def _fitted_rivals(diagnosis: Diagnosis, margin: float, count: int) -> list[Rival]:
    """The search's fits within ``margin`` (N^2) of the extended model's held-out MSE."""
    final = diagnosis.extended
    close = sorted((f for f in diagnosis.explored
                    if set(f.model.causes) != set(final.model.causes)
                    and f.failed_test is None
                    and f.heldout_rmse_n**2 <= final.heldout_rmse_n**2 + margin),
                   key=lambda f: f.heldout_rmse_n)[:count]
    return [Rival(f.model.name, f.model.causes, f.material, f.offset_n, f.rmse_n)
            for f in close]


def _with_cause(model: CandidateMaterial, cause: str) -> CandidateMaterial | None:
    """``model`` plus ``cause`` (the non-linear viscoelasticity in place of the quasi-linear
    one; None where it makes no other model: a non-linear relaxation with no relaxation to
    start from, a quasi-linear one beside the non-linear)."""
    if cause == EXCLUSIVE[1]:
        if EXCLUSIVE[0] not in model.causes:
            return None
        return replace(model, causes=(*[c for c in model.causes if c != EXCLUSIVE[0]], cause))
    if cause == EXCLUSIVE[0] and EXCLUSIVE[1] in model.causes:
        return None
    return replace(model, causes=(*model.causes, cause), stiffening="exponential")


def _shape_from(fitted: ModelFit, model: CandidateMaterial,
                typical: dict[str, float]) -> np.ndarray:
    """``model``'s shape: the fitted values where the names match, ``typical`` for the added
    cause's, the model's start elsewhere."""
    names = fitted.model.parameter_names
    shape = model.initial.copy()
    for i, name in enumerate(model.parameter_names):
        if name in typical:
            shape[i] = typical[name]
        elif name in names:
            shape[i] = fitted.shape[names.index(name)]
    return shape


def _probe(problem: Problem, model: CandidateMaterial, shape: np.ndarray,
           measured: np.ndarray) -> tuple[MassSpringMaterial, float, float] | None:
    """``model`` at ``shape`` with E and the offset solved on the set: material, offset (N)
    and RMSE on the fitted samples (N); None when the material cannot run the set."""
    units = problem.unit_forces(model, shape, problem.thinned)
    if units is None:
        return None
    unit = np.concatenate(units)
    scale, offset = scale_and_offset(unit, measured, model.has_offset)
    rmse = float(np.sqrt(np.mean((scale * unit + offset - measured) ** 2)))
    return (model.material(shape, scale * REFERENCE_PA, problem.specimen.density_kg_m3),
            offset, rmse)


def _typical_rivals(diagnosis: Diagnosis, problem: Problem, margin: float) -> list[Rival]:
    """Per cause the extended model lacks, that model with the cause at each of its typical
    magnitudes, where it fits the set within ``margin`` (N^2) of the extended model's MSE."""
    final = diagnosis.extended
    measured = np.concatenate([t.force_n for t in problem.thinned])
    rivals = []
    for cause in (c for c in CAUSES if c in TYPICAL and c not in final.model.causes):
        model = _with_cause(final.model, cause)
        if model is None:
            continue
        for typical in TYPICAL[cause]:
            probed = _probe(problem, model, _shape_from(final, model, typical), measured)
            if probed is not None and probed[2] ** 2 <= final.rmse_n**2 + margin:
                sign = "" if len(TYPICAL[cause]) == 1 else (
                    " (+)" if min(typical.values()) > 0 else " (-)")
                rivals.append(Rival(f"{model.name}, {cause} at a typical magnitude{sign}",
                                    model.causes, probed[0], probed[1], probed[2], cause))
    return rivals


def rivals(diagnosis: Diagnosis, params: SuggestParams | None = None) -> list[Rival]:
    """The models that explain the set of ``diagnosis`` about as well as its extended model
    (module docstring, 1)."""
    params = SuggestParams() if params is None else params
    margin = diagnosis.params.min_variance_drop * diagnosis.noise_n**2
    problem = Problem.of(diagnosis.measurements.specimen, diagnosis.measurements.tests,
                         diagnosis.params.fit_samples)
    return (_fitted_rivals(diagnosis, margin, params.max_fitted_rivals)
            + _typical_rivals(diagnosis, problem, margin))


def _forces(tests: list[MechanicalTest], specimen: Specimen, lattice: SpecimenLattice,
            material: MassSpringMaterial, offset_n: float) -> list[np.ndarray | None]:
    """Each candidate test's predicted force with ``material``, N (None where it cannot run:
    the tests are run one by one then, to find which)."""
    try:
        return [run.force_n + offset_n
                for run in simulate_tests(tests, specimen, material, lattice)]
    except MaterialError:
        return [None] * len(tests)
    except DivergenceError:
        forces: list[np.ndarray | None] = []
        for test in tests:
            try:
                forces.append(simulate_tests((test,), specimen, material, lattice)[0].force_n
                              + offset_n)
            except DivergenceError:
                forces.append(None)
        return forces


def _spread_sd(diagnosis: Diagnosis) -> float:
    """The specimen spread of the set, where ``specimen_variability`` is named, else 0."""
    return diagnosis.specimen.sd if diagnosis.specimen.named else 0.0


def suggest(diagnosis: Diagnosis, params: SuggestParams | None = None) -> Suggestion:
    """The next test to run on the set of ``diagnosis`` (module docstring)."""
    params = SuggestParams() if params is None else params
    found = tuple(rivals(diagnosis, params))
    spread = _spread_sd(diagnosis)
    if not found:
        return Suggestion(False, found, spread_sd=spread)
    candidates = candidate_tests(diagnosis.measurements)
    specimen = diagnosis.measurements.specimen
    lattice = SpecimenLattice.of(specimen)
    tests = [c.mechanical_test(specimen, f"next-{k}") for k, c in enumerate(candidates)]
    final = diagnosis.extended
    chosen = _forces(tests, specimen, lattice, final.material, final.offset_n)
    others = [_forces(tests, specimen, lattice, r.material, r.offset_n) for r in found]
    noise = max(diagnosis.noise_n, 1e-12)
    scores, best = [], []
    for k, own in enumerate(chosen):
        separations = []
        for i, forces in enumerate(others):
            if own is None or forces[k] is None:
                continue
            scatter = np.sqrt(noise**2 + (spread * 0.5 * (np.abs(own) + np.abs(forces[k])))**2)
            difference = own - forces[k]
            separations.append((float(np.sqrt(np.mean((difference / scatter) ** 2))), i,
                                float(np.sqrt(np.mean(difference**2))),
                                float(np.sqrt(np.mean(scatter**2)))))
        # Ties of the capped sum (tests that tell every rival apart for sure) go to the one
        # whose predictions differ most.
        scores.append((sum(min(s[0], params.cap) for s in separations),
                       sum(s[0] for s in separations)))
        best.append(max(separations, default=(0.0, -1, 0.0, noise)))
    order = sorted(range(len(candidates)), key=lambda k: scores[k], reverse=True)
    top = order[0]
    _, rival, difference, scatter = best[top]
    return Suggestion(True, found, candidates[top], found[rival] if rival >= 0 else None,
                      difference, scatter, scores[top][0],
                      tuple((candidates[k], scores[k][0]) for k in order[:5]), spread)
