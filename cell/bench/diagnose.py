"""``musclecell bench diagnose``: the diagnosis on hidden-effect sets it has never seen.

Each set is drawn by the project's hidden-effect generator (:mod:`cell.rheology.synthetic`) with a
seed the tests never use, so that the magnitude, the noise, the mid angle and the rates are all
unseen; the hidden effect cycles through the catalogue and none with the seed, so that ten sets or
more try every one. Every set is written to a temporary folder, read back, and diagnosed; the wall
time of :func:`diagnose` is measured per set. A set is correct when the catalogue causes it names
(``unexplained`` aside) are exactly its hidden effect, or none when none is hidden.

Targets: at most 60 s per ten-test set (the slowest set), at least 9 sets in 10 correct.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from cell.errors import MeasurementError
from cell.rheology import synthetic as generator

#: Target: wall time of one diagnosis of a ten-test set, s (the slowest set counts).
TARGET_SECONDS_PER_SET = 60.0
#: Target: fraction of the sets whose causes are exactly the hidden effect.
TARGET_CORRECT = 0.9
#: The first seed of the bench; the tests use seeds below it.
FIRST_SEED = 10_000


def bench_seeds(count: int) -> list[int]:
    """The seeds of ``count`` bench sets."""
    return [FIRST_SEED + i for i in range(count)]


def _label(causes: Sequence[str]) -> str:
    return "+".join(causes) or "none"


def confusion_markdown(confusion: dict[str, dict[str, int]]) -> str:
    """The confusion table (truth rows, named columns) as Markdown."""
    named = sorted({n for row in confusion.values() for n in row})
    lines = ["| truth | " + " | ".join(named) + " |",
             "| --- | " + " | ".join("---:" for _ in named) + " |"]
    for truth in sorted(confusion):
        cells = [str(confusion[truth].get(n, 0) or "") for n in named]
        lines.append(f"| {truth} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def run_diagnose_bench(seeds: Sequence[int], workers: int = 2,
                       progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Diagnose one hidden-effect set per seed; times, correctness, confusion, targets.

    Args:
        seeds: one set per seed (:func:`bench_seeds` gives seeds the tests never use).
        workers: ``DiagnosisParams.workers``: 2, the cores of the machine the target is for
            (and ``musclecell diagnose``'s default).
        progress: called with one line per set.

    Raises:
        MeasurementError: no seed.
    """
    if not seeds:
        raise MeasurementError(None, "seeds", "the diagnose bench needs at least one seed")
    from cell.rheology.diagnosis import CAUSES, DiagnosisParams, diagnose
    from cell.rheology.measured import load_measurement_set

    params = DiagnosisParams(workers=workers)
    sets: list[dict[str, Any]] = []
    confusion: dict[str, dict[str, int]] = {}
    with tempfile.TemporaryDirectory(prefix="bench-diagnose-") as scratch:
        for seed in seeds:
            folder = Path(scratch) / f"set-{seed}"
            effect = generator.EFFECTS[seed % len(generator.EFFECTS)]
            truth = generator.write_hidden_effect_set(folder, seed, effect)
            data = load_measurement_set(folder)
            start = time.perf_counter()
            result = diagnose(data, params)
            seconds = time.perf_counter() - start
            named = [c for c in result.causes if c in CAUSES]
            expected = [] if truth.effect is None else [truth.effect]
            truth_label, named_label = _label(expected), _label(result.causes)
            row = confusion.setdefault(truth_label, {})
            row[named_label] = row.get(named_label, 0) + 1
            sets.append({
                "seed": seed, "truth": generator.describe(truth),
                "causes": list(result.causes), "correct": named == expected,
                "first_correct": (named[:1] == expected[:1]),
                "gain": float(result.gain), "seconds": seconds,
                "tests": len(data.tests), "samples": sum(len(t.time_s) for t in data.tests),
            })
            if progress is not None:
                progress(f"seed {seed}: truth {truth_label}, named {named_label}, "
                         f"gain {result.gain:.2f}, {seconds:.1f} s")
    times = [s["seconds"] for s in sets]
    correct = sum(s["correct"] for s in sets)
    first = sum(s["first_correct"] for s in sets)
    count = len(sets)
    entries = {
        "seconds_per_set_median": {"value": statistics.median(times), "unit": "s"},
        "seconds_per_set_max": {"value": max(times), "unit": "s"},
        "tests_per_set": {"value": statistics.median(s["tests"] for s in sets),
                          "unit": "tests"},
        "samples_per_set": {"value": statistics.median(s["samples"] for s in sets),
                            "unit": "samples"},
        "correct": {"value": correct / count, "unit": "fraction", "count": correct,
                    "of": count},
        "first_cause_correct": {"value": first / count, "unit": "fraction", "count": first,
                                "of": count},
    }
    targets = {
        "time_per_set": {"value": max(times), "target": TARGET_SECONDS_PER_SET, "unit": "s",
                         "pass": max(times) <= TARGET_SECONDS_PER_SET},
        "correct": {"value": correct / count, "target": TARGET_CORRECT, "unit": "fraction",
                    "pass": correct / count >= TARGET_CORRECT},
    }
    return {"suite": "diagnose", "workers": workers, "seeds": list(seeds), "sets": sets,
            "entries": entries, "confusion": confusion,
            "markdown": confusion_markdown(confusion), "targets": targets}
