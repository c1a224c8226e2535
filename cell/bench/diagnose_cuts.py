"""``musclecell bench diagnose --cut``: the diagnosis of cut tests on hidden-effect cut sets it
has never seen.

Each set is made by the full simulation of a cut (:func:`cell.synthetic.cut.write_hidden_cut_set`,
on a finer mesh than the cell's) with a seed the tests never use, read back and diagnosed on
the reduced model (:func:`cell.diagnosis.cut.search.diagnose_cuts`). Two kinds (:data:`KINDS`):
``single`` cycles through the cut catalogue and none; ``pairs`` through every pair of it.

Per set: whether the causes named are exactly the hidden ones; for a single cause, the named
cause's fitted parameters against the truth (the norm of the error over the norm of the
truth); the wall time of the diagnosis and of the simulation that made the set; and the
reduced model's agreement with the full simulation (``cut_reduced_vs_full``): the reduced
model with the set's true cutting model and offset against the measured force, its RMSE with
the set's noise taken out, over the set's peak force; and the reduced model's wall time for
the set's tests beside the full simulation's (``cut_reduced_seconds_per_set_median``).

Targets: exact on >= 90 % of single sets and >= 70 % of pairs, the parameters
within 15 % in >= 80 % of the single sets with a cause, none named in >= 90 % of sets with
none, a diagnosis median <= 60 s and max <= 120 s per ten-test set, the reduced model within
10 % of the peak force on every set.
"""

from __future__ import annotations

import itertools
import math
import statistics
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np

from cell.bench.diagnose import (
    cause_label,
    check_request,
    confusion_markdown,
    cycled_causes,
    fraction,
    time_summary,
)
from cell.tissue.cutmodel import CUT_CAUSES, CuttingParams

Kind = Literal["single", "pairs"]
KINDS: tuple[Kind, ...] = ("single", "pairs")
#: The first seed of each kind; the tests use seeds below 10 000, the tuning of the cut
#: diagnosis seeds from 60 000 on.
FIRST_SEED: dict[str, int] = {"single": 41_000, "pairs": 51_000}
PAIRS = tuple(itertools.combinations(CUT_CAUSES, 2))
TARGET_CORRECT: dict[str, float] = {"single": 0.9, "pairs": 0.7}
TARGET_PARAMS_WITHIN = 0.8
PARAMS_TOLERANCE = 0.15
TARGET_NONE = 0.9
TARGET_SECONDS_MEDIAN = 60.0
TARGET_SECONDS_PER_SET = 120.0
TARGET_REDUCED_VS_FULL = 0.10


def bench_seeds(count: int, kind: Kind = "single") -> list[int]:
    """The seeds of ``count`` bench sets of ``kind``."""
    return [FIRST_SEED[kind] + i for i in range(count)]


def hidden(seed: int, kind: Kind) -> tuple[str, ...]:
    """The causes hidden in the set of ``seed``: the catalogue in turn and none twice
    (single: 44 sets hold each cause 4 times and none 8 times), or every pair in turn.

    Example:
        >>> hidden(41_000, "single"), hidden(41_008, "single"), hidden(41_009, "single")
        (('blade_friction',), ('wedge_friction',), ())
    """
    return cycled_causes(seed - FIRST_SEED[kind], CUT_CAUSES, 2,
                         PAIRS if kind == "pairs" else None)


def _truth_vector(cause: str, cutting: CuttingParams, offset_n: Sequence[float]
                  ) -> np.ndarray | None:
    """The parameters of ``cause`` in ``cutting`` (or the sensor's offset), or None for an
    unknown cause."""
    if cause == "blade_friction":
        return np.array([cutting.face_friction])
    if cause == "slicing":
        return np.array([cutting.slicing_efficiency])
    if cause == "rate_dependent_cutting":
        return np.array([cutting.rate_exponent])
    if cause == "indentation_stiffness":
        return np.array([cutting.indentation_depth_m])
    if cause == "layered_toughness":
        return np.array([*cutting.layer_depths_m, *cutting.layer_factors[1:]])
    if cause == "blade_force_offset":
        return np.asarray(offset_n, dtype=float)
    if cause == "edge_loading":
        return np.array([cutting.loading_depth_m])
    if cause == "edge_friction":
        return np.array([cutting.edge_friction, cutting.edge_slip_m])
    if cause == "wedge_friction":
        return np.array([cutting.face_modulus_pa])
    return None


def parameter_error(cause: str, truth: Any, fitted: CuttingParams,
                    fitted_offset_n: np.ndarray) -> float | None:
    """Norm of the named cause's fitted parameters' error over the norm of the truth's, or
    None for an unknown cause."""
    expected = _truth_vector(cause, truth.cutting, truth.offset_n)
    if expected is None:
        return None
    found = _truth_vector(cause, fitted, fitted_offset_n)
    if found is None or found.shape != expected.shape:
        return math.inf
    return float(np.linalg.norm(found - expected) / max(np.linalg.norm(expected), 1e-12))


def reduced_vs_full(data: Any, truth: Any) -> tuple[float, float]:
    """The reduced model's RMSE against the full simulation's force (the measured one, its
    noise taken out), over the set's peak force; and the wall time the reduced model took for
    the set's tests, s."""
    from cell.diagnosis.cut.reduced import reduced_cut_forces

    errors, peak, seconds = [], 0.0, 0.0
    for test in data.cut_tests:
        start = time.perf_counter()
        forces = reduced_cut_forces(test, data.block, data.blade, truth.cutting)
        seconds += time.perf_counter() - start
        predicted = forces.total_n + np.asarray(truth.offset_n)
        errors.append((predicted - test.force_n).ravel())
        peak = max(peak, float(np.abs(test.force_n).max()))
    rmse = float(np.sqrt(np.mean(np.concatenate(errors) ** 2)))
    return math.sqrt(max(rmse**2 - truth.noise_n**2, 0.0)) / max(peak, 1e-12), seconds


def run_cut_diagnose_bench(seeds: Sequence[int], kind: Kind = "single",
                           progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Make, read and diagnose one hidden-effect cut set of ``kind`` per seed (module
    docstring).

    Raises:
        MeasurementError: no seed, or an unknown kind.
    """
    check_request(seeds, kind, KINDS)
    from cell.diagnosis.cut.search import diagnose_cuts
    from cell.diagnosis.engine.settings import DiagnosisParams
    from cell.measure.specimens import load_measurement_set
    from cell.synthetic.cut import describe, write_hidden_cut_set

    params = DiagnosisParams(workers=1)
    sets, confusion = [], {}
    with tempfile.TemporaryDirectory(prefix="bench-cut-diagnose-") as scratch:
        for seed in seeds:
            expected = hidden(seed, kind)
            folder = Path(scratch) / f"set-{seed}"
            truth = write_hidden_cut_set(folder, seed, expected)
            data = load_measurement_set(folder)
            start, cpu_start = time.perf_counter(), time.process_time()
            result = diagnose_cuts(data.block, data.blade, data.cut_tests, params)
            seconds = time.perf_counter() - start
            cpu_seconds = time.process_time() - cpu_start
            agreement, reduced_s = reduced_vs_full(data, truth)
            named = [c for c in result.causes if c in CUT_CAUSES]
            error = (parameter_error(expected[0], truth, result.extended.cutting,
                                     result.extended.offset_n)
                     if len(expected) == 1 and named == list(expected) else None)
            row = confusion.setdefault(cause_label(expected), {})
            row[cause_label(result.causes)] = row.get(cause_label(result.causes), 0) + 1
            sets.append({"seed": seed, "truth": describe(truth), "causes": list(result.causes),
                         "correct": sorted(named) == sorted(expected),
                         "parameter_error": error, "gain": float(result.gain),
                         "seconds": seconds, "cpu_seconds": cpu_seconds,
                         "simulation_seconds": truth.wall_s,
                         "reduced_vs_full": agreement, "reduced_seconds": reduced_s,
                         "tests": len(data.cut_tests)})
            if progress is not None:
                progress(f"seed {seed}: truth {cause_label(expected)}, named "
                         f"{cause_label(result.causes)}, {seconds:.1f} s ({cpu_seconds:.1f} s of "
                         f"CPU; simulated in "
                         f"{truth.wall_s:.0f} s), reduced vs full "
                         f"{sets[-1]['reduced_vs_full']:.3f}")
    return _summary(sets, confusion, kind, seeds)


def _summary(sets: list[dict[str, Any]], confusion: dict[str, dict[str, int]], kind: str,
             seeds: Sequence[int]) -> dict[str, Any]:
    """The bench's JSON: sets, entries, targets, the confusion table."""
    times = [s["seconds"] for s in sets]
    agreement = [s["reduced_vs_full"] for s in sets]
    with_cause = [s for s in sets if s["truth"]["causes"]]
    without = [s for s in sets if not s["truth"]["causes"]]
    compared = [s["parameter_error"] for s in with_cause if s["parameter_error"] is not None]
    time_entries, time_targets = time_summary(times, TARGET_SECONDS_MEDIAN,
                                              TARGET_SECONDS_PER_SET)
    entries = {
        **time_entries,
        # The process's own CPU time: what the diagnosis costs on a machine that other jobs
        # share (the wall time above waits for them too).
        "cpu_seconds_per_set_median": {
            "value": statistics.median(s["cpu_seconds"] for s in sets), "unit": "s"},
        "cpu_seconds_per_set_max": {"value": max(s["cpu_seconds"] for s in sets), "unit": "s"},
        "simulation_seconds_per_set_median": {
            "value": statistics.median(s["simulation_seconds"] for s in sets), "unit": "s"},
        "correct": {"value": fraction([s["correct"] for s in sets]), "unit": "fraction",
                    "of": len(sets)},
        "cut_reduced_vs_full_median": {"value": statistics.median(agreement),
                                       "unit": "fraction of the peak force"},
        "cut_reduced_vs_full_max": {"value": max(agreement),
                                    "unit": "fraction of the peak force"},
        # What the diagnosis's thousands of evaluations rest on: the reduced model of a set's
        # tests against the full simulation that made them.
        "cut_reduced_seconds_per_set_median": {
            "value": statistics.median(s["reduced_seconds"] for s in sets), "unit": "s",
            "peer": statistics.median(s["simulation_seconds"] for s in sets),
            "peer_name": "the full simulation of the same tests",
            "ratio": statistics.median(s["reduced_seconds"] / s["simulation_seconds"]
                                       for s in sets)},
    }
    targets = {
        "correct": {"value": entries["correct"]["value"], "target": TARGET_CORRECT[kind],
                    "unit": "fraction",
                    "pass": entries["correct"]["value"] >= TARGET_CORRECT[kind]},
        **time_targets,
        "cut_reduced_vs_full": {"value": max(agreement), "target": TARGET_REDUCED_VS_FULL,
                                "unit": "fraction of the peak force",
                                "pass": max(agreement) <= TARGET_REDUCED_VS_FULL},
    }
    if compared:
        within = fraction([e <= PARAMS_TOLERANCE for e in compared])
        entries["parameters_within_15_percent"] = {"value": within, "unit": "fraction",
                                                   "of": len(compared)}
        targets["parameters_within_15_percent"] = {"value": within,
                                                   "target": TARGET_PARAMS_WITHIN,
                                                   "unit": "fraction",
                                                   "pass": within >= TARGET_PARAMS_WITHIN}
    if without:
        none = fraction([not s["causes"] for s in without])
        entries["none_named_without_cause"] = {"value": none, "unit": "fraction",
                                               "of": len(without)}
        targets["none_named_without_cause"] = {"value": none, "target": TARGET_NONE,
                                               "unit": "fraction", "pass": none >= TARGET_NONE}
    return {"suite": "diagnose", "kind": f"cut {kind}", "seeds": list(seeds), "sets": sets,
            "entries": entries, "confusion": confusion,
            "markdown": confusion_markdown(confusion), "targets": targets}
