"""``musclecell bench diagnose --spread``: sets of tests repeated under equal conditions, each
test another specimen, diagnosed unseen.

Per seed two sets of the same structure (the hidden-effect protocol's ten tests, three times
each: thirty tests, :class:`~cell.synthetic.specimen.Repeats`) and the same draws: one with a
hidden specimen spread (the standard deviation of the log modulus factor drawn in
:data:`SPREAD_RANGE`), one without. The material effect hidden beside it cycles through the
catalogue and none with the seed, as the ``single`` kind of :mod:`cell.bench.diagnose` does.
Each set is written to a temporary folder, read back and diagnosed; the wall time of
:func:`~cell.diagnosis.specimen.diagnosis.diagnose` is measured per set.

Targets (:data:`TARGETS`): ``specimen_variability`` named in >= 90 % of the sets with a spread
and <= 10 % of those without; the fitted spread within 35 % of the truth in >= 75 % of the
sets with one; the 90 % intervals of the held-out predictions covering 85 to 95 % of the
held-out samples (the median over sets, for each kind of set); median <= 45 s and max <= 90 s
per set.

With ``by_specimen`` (``--spread --by-specimen``) the sets name their specimens instead:
:data:`SPECIMENS` specimens each running the protocol's first :data:`SPECIMEN_CONDITIONS`
tests (the ramps), one modulus factor per specimen with a coefficient of variation drawn in
:data:`CV_RANGE` (or none), in the ``specimen`` column; the diagnosis then leaves whole
specimens out (:mod:`cell.diagnosis.specimen.specimenids`). Fresh seeds from
:data:`FIRST_SPECIMEN_SEED`; the fitted spread is judged against the specimens' realised
spread (their log factors' sample sd), which five specimens draw far from the population's.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cell.bench.diagnose import check_request, hidden, time_summary
from cell.cores import default_workers
from cell.synthetic import specimen as generator

#: The spread's standard deviation (of the log modulus factor) is drawn in this range.
SPREAD_RANGE = (0.10, 0.30)
#: Conditions and repeats of a set.
CONDITIONS, REPEATS = 10, 3
#: The first seed; the tests use seeds below 10 000, the tuning 90 000 to 93 999.
FIRST_SEED = 60_000
#: Targets: wall time of one diagnosis of a thirty-test set, s (the median, the slowest).
TARGET_SECONDS_MEDIAN = 45.0
TARGET_SECONDS_PER_SET = 90.0
#: Targets on fractions of sets (module docstring).
TARGETS = {"named_with_spread": 0.9, "named_without_spread": 0.1, "spread_within_35pc": 0.75}
#: Target range of the median coverage of the held-out samples by their 90 % intervals.
TARGET_COVERAGE = (0.85, 0.95)
KINDS = ("spread", "no_spread")
#: With ``by_specimen``: the coefficient of variation of the specimens' modulus factor is
#: drawn in this range; conditions run by each specimen; specimens of a set; the first seed.
CV_RANGE = (0.05, 0.25)
SPECIMEN_CONDITIONS, SPECIMENS = 5, 5
FIRST_SPECIMEN_SEED = 70_000


def bench_seeds(count: int, by_specimen: bool = False) -> list[int]:
    """The seeds of ``count`` pairs of sets."""
    return [(FIRST_SPECIMEN_SEED if by_specimen else FIRST_SEED) + i for i in range(count)]


def spread_sd(seed: int, by_specimen: bool = False) -> float:
    """The hidden spread of the set of ``seed`` with one (its own stream: the set's other draws
    are those of the set without); with ``by_specimen``, the sd whose lognormal factor has a
    coefficient of variation drawn in :data:`CV_RANGE`."""
    rng = np.random.default_rng([seed, 2])
    if by_specimen:
        return float(np.sqrt(np.log1p(rng.uniform(*CV_RANGE) ** 2)))
    return float(rng.uniform(*SPREAD_RANGE))


def _design(sd: float, by_specimen: bool) -> generator.Repeats:
    """The repeats of a set: named specimens running the ramps, or each test another."""
    if by_specimen:
        return generator.Repeats(SPECIMEN_CONDITIONS, SPECIMENS, sd, named=True)
    return generator.Repeats(CONDITIONS, REPEATS, sd)


def run_one(folder: Path, seed: int, kind: str, workers: int,
            by_specimen: bool = False) -> dict[str, Any]:
    """Write, read and diagnose the set of ``seed`` and ``kind``: its row of the bench."""
    from cell.diagnosis.engine.settings import DiagnosisParams
    from cell.diagnosis.specimen.causes import CAUSES
    from cell.diagnosis.specimen.diagnosis import diagnose
    from cell.measure.specimens import load_measurement_set

    effects = hidden(seed, "single")
    sd = spread_sd(seed, by_specimen) if kind == "spread" else 0.0
    truth = generator.write_hidden_effect_set(folder, seed, effects,
                                              repeats=_design(sd, by_specimen))
    # Named specimens: the spread their factors realise (one factor per specimen).
    realised = (float(np.std(np.log(truth.specimen_factors[:SPECIMENS]), ddof=1))
                if by_specimen else sd)
    data = load_measurement_set(folder)
    start = time.perf_counter()
    result = diagnose(data, DiagnosisParams(workers=workers))
    seconds = time.perf_counter() - start
    named = [c for c in result.causes if c in CAUSES]
    intervals = result.intervals
    return {"seed": seed, "kind": kind, "truth": generator.describe(truth),
            "causes": list(result.causes), "spread_sd_truth": sd,
            "spread_named": "specimen_variability" in result.causes,
            "spread_sd_fitted": result.specimen.sd, "spread_ci95": list(result.specimen.ci95),
            "spread_sd_realised": realised, "by_specimen": by_specimen,
            "spread_within_35pc": sd > 0 and abs(result.specimen.sd - realised)
            <= 0.35 * realised,
            "specimen_factors": {k: f.factor for k, f in result.specimen.specimens.items()},
            "material_causes_correct": sorted(named) == sorted(effects),
            "coverage": intervals.overall_coverage if intervals else float("nan"),
            "coverage_per_test": dict(zip(intervals.test_ids, intervals.coverage, strict=True))
            if intervals else {},
            "interval_parts_rms_N": intervals.parts_n if intervals else {},
            "repeat_groups": len(result.specimen.groups), "seconds": seconds,
            "tests": len(data.tests)}


def run_spread_bench(seeds: Sequence[int], workers: int | None = None,
                     progress: Callable[[str], None] | None = None,
                     kinds: Sequence[str] = KINDS, by_specimen: bool = False
                     ) -> dict[str, Any]:
    """Diagnose the sets of each seed and kind (module docstring; ``by_specimen``: sets that
    name their specimens): rows, entries, targets.

    Raises:
        MeasurementError: no seed, or an unknown kind.
    """
    for kind in kinds:
        check_request(seeds, kind, KINDS)
    workers = workers or default_workers()
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-spread-") as scratch:
        for seed in seeds:
            for kind in kinds:
                row = run_one(Path(scratch) / f"{kind}-{seed}", seed, kind, workers,
                              by_specimen)
                rows.append(row)
                if progress is not None:
                    progress(f"seed {seed} {kind}: spread {row['spread_sd_truth']:.3f}, fitted "
                             f"{row['spread_sd_fitted']:.3f}, named {'+'.join(row['causes'])}"
                             f", coverage {row['coverage']:.3f}, {row['seconds']:.1f} s")
    return summarize(rows, workers, list(seeds))


def summarize(rows: list[dict[str, Any]], workers: int, seeds: list[int]) -> dict[str, Any]:
    """The bench's JSON from its rows (several runs' rows may be joined)."""
    entries: dict[str, Any] = {}
    targets: dict[str, Any] = {}
    for kind in KINDS:
        kept = [r for r in rows if r["kind"] == kind]
        if not kept:
            continue
        named = sum(r["spread_named"] for r in kept)
        coverage = [r["coverage"] for r in kept]
        entries[f"{kind}_named"] = {"value": named / len(kept), "unit": "fraction",
                                    "count": named, "of": len(kept)}
        entries[f"{kind}_coverage_median"] = {"value": statistics.median(coverage),
                                              "unit": "fraction"}
        entries[f"{kind}_coverage_range"] = {"value": max(coverage) - min(coverage),
                                             "unit": "fraction", "min": min(coverage),
                                             "max": max(coverage),
                                             "quartiles": statistics.quantiles(coverage, n=4)
                                             if len(coverage) > 1 else coverage * 3}
        entries[f"{kind}_material_causes_correct"] = {
            "value": sum(r["material_causes_correct"] for r in kept) / len(kept),
            "unit": "fraction", "of": len(kept)}
        median = statistics.median(coverage)
        targets[f"{kind}_coverage_median"] = {
            "value": median, "target": TARGET_COVERAGE[0], "unit": "fraction",
            "pass": TARGET_COVERAGE[0] <= median <= TARGET_COVERAGE[1]}
        key = "named_with_spread" if kind == "spread" else "named_without_spread"
        share = named / len(kept)
        targets[key] = {"value": share, "target": TARGETS[key], "unit": "fraction",
                        "pass": share >= TARGETS[key] if kind == "spread"
                        else share <= TARGETS[key]}
        if kind == "spread":
            within = sum(r["spread_within_35pc"] for r in kept) / len(kept)
            entries["spread_within_35pc"] = {"value": within, "unit": "fraction"}
            targets["spread_within_35pc"] = {"value": within,
                                             "target": TARGETS["spread_within_35pc"],
                                             "unit": "fraction",
                                             "pass": within >= TARGETS["spread_within_35pc"]}
    time_entries, time_targets = time_summary([r["seconds"] for r in rows],
                                              TARGET_SECONDS_MEDIAN, TARGET_SECONDS_PER_SET)
    kind = "spread-by-specimen" if any(r.get("by_specimen") for r in rows) else "spread"
    return {"suite": "diagnose", "kind": kind, "workers": workers, "seeds": seeds,
            "sets": rows, "entries": {**time_entries, **entries},
            "targets": {**time_targets, **targets}, "markdown": markdown(rows)}


def markdown(rows: list[dict[str, Any]]) -> str:
    """One line per set: seed, kind, spread (truth, fitted), causes, coverage, seconds."""
    lines = ["| seed | kind | spread truth | fitted | named | coverage | s |",
             "| --- | --- | ---: | ---: | --- | ---: | ---: |"]
    lines += [f"| {r['seed']} | {r['kind']} | {r['spread_sd_truth']:.3f} | "
              f"{r['spread_sd_fitted']:.3f} | {', '.join(r['causes']) or 'none'} | "
              f"{r['coverage']:.3f} | {r['seconds']:.1f} |" for r in rows]
    return "\n".join(lines) + "\n"
