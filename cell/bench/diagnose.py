"""``musclecell bench diagnose``: the diagnosis on hidden-effect sets it has never seen.

Each set is drawn by the project's hidden-effect generator (:mod:`cell.synthetic.specimen`) with a
seed the tests never use, so that the magnitudes, the noise, the mid angle and the rates are all
unseen. Three kinds of sets (:data:`KINDS`):

- ``single``: the hidden effect cycles through the catalogue and none with the seed;
- ``subtle``: the same, every effect half as strong;
- ``pairs``: two causes at once, cycling through every pair of the catalogue (never both
  viscoelasticities);
- ``triples``: three causes at once, cycling through every triple of the catalogue (never both
  viscoelasticities).

``including`` keeps the pairs or triples that hold one cause (``--including force_offset``:
the load cell's offset beside each other effect), on seeds of their own. ``protocol="lab"``
(``--lab-protocol``) draws the sets as another generator would: slow tension, relaxation and
cyclic tests, less noise and larger offsets (:func:`generator.write_hidden_effect_set`), on
seeds of their own.

Every set is written to a temporary folder, read back, and diagnosed; the wall time of
:func:`diagnose` is measured per set. A set is correct when the catalogue causes it names
(``unexplained`` aside) are exactly its hidden effects, or none when none is hidden; a pair or a
triple is half right when at least one of its causes is named. The ``single`` kind also
diagnoses the relaxation-only set shaped like published muscle tests
(:func:`write_relaxation_set`).

Targets: median <= 20 s and max <= 60 s per ten-test set, the relaxation set in <= 60 s and
named ``nonlinear_viscoelasticity`` first with a gain >= 0.7; exact: >= 95 % of single sets,
>= 80 % of subtle and of pair sets (those with one cause included too), >= 60 % of triples,
and at least one of the two named in >= 97 % of pairs.
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

from cell.errors import MeasurementError
from cell.synthetic import specimen as generator

Kind = Literal["single", "subtle", "pairs", "triples"]
KINDS: tuple[Kind, ...] = ("single", "subtle", "pairs", "triples")
#: Targets: wall time of one diagnosis of a ten-test set, s (the median, the slowest).
TARGET_SECONDS_MEDIAN = 20.0
TARGET_SECONDS_PER_SET = 60.0
#: Target: fraction of the sets whose causes are exactly the hidden ones, per kind.
TARGET_CORRECT: dict[str, float] = {"single": 0.95, "subtle": 0.8, "pairs": 0.8,
                                     "triples": 0.6}
#: Target: fraction of the pair sets with at least one of their two causes named.
TARGET_ONE_OF_PAIR = 0.97
#: Targets of the relaxation-only set: wall time, s, and gain.
TARGET_RELAXATION_SECONDS = 60.0
TARGET_RELAXATION_GAIN = 0.7
#: The first seed of each kind (and of pairs or triples that include one cause); the tests use
#: seeds below 10 000, the tuning seeds from 90 000 to 99 999.
FIRST_SEED: dict[str, int] = {"single": 10_000, "subtle": 20_000, "pairs": 30_000,
                              "triples": 130_000, "including": 33_000}
#: Added to a kind's first seed for the sets of the lab protocol.
LAB_SEEDS = 13_000
Protocol = Literal["hidden", "lab"]


def _combinations(size: int) -> tuple[tuple[str, ...], ...]:
    """Every ``size`` causes a set may hide together (one viscoelasticity at most)."""
    return tuple(c for c in itertools.combinations(generator.UNIAXIAL_CAUSES, size)
                 if not {"viscoelasticity", "nonlinear_viscoelasticity"} <= set(c))


PAIRS = _combinations(2)
TRIPLES = _combinations(3)


def bench_seeds(count: int, kind: Kind = "single", including: str | None = None,
                protocol: Protocol = "hidden") -> list[int]:
    """The seeds of ``count`` bench sets of ``kind`` (with ``including``, or of the lab
    protocol: their own)."""
    first = FIRST_SEED[kind] if including is None else FIRST_SEED["including"] + (
        100_000 if kind == "triples" else 0)
    return [first + (LAB_SEEDS if protocol == "lab" else 0) + i for i in range(count)]


def hidden(seed: int, kind: Kind, including: str | None = None) -> tuple[str, ...]:
    """The causes a bench set of ``kind`` hides, cycling with its seed (through the pairs or
    triples that hold ``including``, when given)."""
    if kind in ("pairs", "triples"):
        chosen = [c for c in (PAIRS if kind == "pairs" else TRIPLES)
                  if including is None or including in c]
        return chosen[seed % len(chosen)]
    effect = generator.EFFECTS[seed % len(generator.EFFECTS)]
    return () if effect is None else (effect,)


def _label(causes: Sequence[str]) -> str:
    return "+".join(causes) or "none"


def cause_label(causes: Sequence[str]) -> str:
    """A set of causes as a confusion table names it.

    Example:
        >>> cause_label(("slicing", "blade_friction")), cause_label(())
        ('blade_friction + slicing', 'none')
    """
    return " + ".join(sorted(causes)) or "none"


def fraction(flags: Sequence[bool]) -> float:
    """The share of true flags (NaN for none)."""
    return sum(flags) / len(flags) if flags else math.nan


def cycled_causes(offset: int, catalogue: Sequence[str], nones: int,
                  pairs: Sequence[tuple[str, str]] | None = None) -> tuple[str, ...]:
    """The causes of the ``offset``-th bench set: every pair in turn when ``pairs`` is given,
    else the catalogue's causes one at a time in turn, then ``nones`` sets with none.

    Example:
        >>> [cycled_causes(k, ("a", "b"), 1) for k in range(4)]
        [('a',), ('b',), (), ('a',)]
    """
    if pairs is not None:
        return pairs[offset % len(pairs)]
    cycle = (*((c,) for c in catalogue), *((),) * nones)
    return cycle[offset % len(cycle)]


def confusion_markdown(confusion: dict[str, dict[str, int]]) -> str:
    """The confusion table (truth rows, named columns) as Markdown."""
    named = sorted({n for row in confusion.values() for n in row})
    lines = ["| truth | " + " | ".join(named) + " |",
             "| --- | " + " | ".join("---:" for _ in named) + " |"]
    for truth in sorted(confusion):
        cells = [str(confusion[truth].get(n, 0) or "") for n in named]
        lines.append(f"| {truth} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def check_request(seeds: Sequence[int], kind: str, kinds: Sequence[str],
                  including: str | None = None) -> None:
    """Check a diagnose bench's seeds, kind and the cause its pairs or triples include.

    Raises:
        MeasurementError: no seed, a kind not in ``kinds``, or ``including`` with a kind other
            than pairs or triples, or not a cause of the catalogue.
    """
    if not seeds:
        raise MeasurementError(None, "seeds", "the diagnose bench needs at least one seed")
    if kind not in kinds:
        raise MeasurementError(None, "kind", f"must be one of {kinds}, got {kind!r}")
    if including is not None and (kind not in ("pairs", "triples")
                                  or including not in generator.UNIAXIAL_CAUSES):
        raise MeasurementError(None, "including", f"a cause of {generator.UNIAXIAL_CAUSES} that "
                               f"pairs or triples include, got {including!r} with {kind}")


def time_summary(times: Sequence[float], median_target: float, max_target: float
                 ) -> tuple[dict[str, Any], dict[str, Any]]:
    """The entries and the targets of a diagnose bench's wall times per set, s: the median
    and the slowest against their targets."""
    entries = {
        "seconds_per_set_median": {"value": statistics.median(times), "unit": "s"},
        "seconds_per_set_max": {"value": max(times), "unit": "s"},
    }
    targets = {
        "time_per_set_median": {"value": statistics.median(times), "target": median_target,
                                "unit": "s", "pass": statistics.median(times) <= median_target},
        "time_per_set": {"value": max(times), "target": max_target, "unit": "s",
                         "pass": max(times) <= max_target},
    }
    return entries, targets


def _diagnose_one(folder: Path, params: Any) -> tuple[Any, float, Any]:
    """Read and diagnose the set in ``folder``: the diagnosis, its wall time (s), the set."""
    from cell.diagnosis.specimen.diagnosis import diagnose
    from cell.measure.specimens import load_measurement_set

    data = load_measurement_set(folder)
    start = time.perf_counter()
    result = diagnose(data, params)
    return result, time.perf_counter() - start, data


def _relaxation_entry(scratch: Path, seed: int, params: Any) -> dict[str, Any]:
    """The relaxation-only set of ``seed``, diagnosed: causes, gain, seconds."""
    truth = generator.write_relaxation_set(scratch / "relaxation", seed)
    result, seconds, data = _diagnose_one(scratch / "relaxation", params)
    return {"seed": seed, "truth": generator.describe(truth), "causes": list(result.causes),
            "gain": float(result.gain), "seconds": seconds, "tests": len(data.tests),
            "first_correct": result.causes[:1] == ("nonlinear_viscoelasticity",)}


def run_diagnose_bench(seeds: Sequence[int], workers: int | None = None,
                       progress: Callable[[str], None] | None = None,
                       kind: Kind = "single", including: str | None = None,
                       protocol: Protocol = "hidden") -> dict[str, Any]:
    """Diagnose one hidden-effect set of ``kind`` per seed; times, correctness, confusion,
    targets (and the relaxation-only set, for the ``single`` kind).

    Args:
        seeds: one set per seed (:func:`bench_seeds` gives seeds the tests never use).
        workers: ``DiagnosisParams.workers`` (default: every core).
        progress: called with one line per set.
        kind: ``single``, ``subtle`` (half as strong), ``pairs`` or ``triples`` (module
            docstring).
        including: with pairs or triples, only those that hold this cause.
        protocol: the generator's own protocol, or ``lab`` (module docstring).

    Raises:
        MeasurementError: no seed, an unknown kind, or a bad ``including``
            (:func:`check_request`).
    """
    check_request(seeds, kind, KINDS, including)
    from cell.diagnosis.engine.settings import DiagnosisParams
    from cell.diagnosis.specimen.causes import CAUSES

    params = DiagnosisParams() if workers is None else DiagnosisParams(workers=workers)
    sets: list[dict[str, Any]] = []
    confusion: dict[str, dict[str, int]] = {}
    relaxation = None
    with tempfile.TemporaryDirectory(prefix="bench-diagnose-") as scratch:
        for seed in seeds:
            folder = Path(scratch) / f"set-{seed}"
            expected = hidden(seed, kind, including)
            truth = generator.write_hidden_effect_set(folder, seed, expected,
                                                      0.5 if kind == "subtle" else 1.0,
                                                      protocol=protocol)
            result, seconds, data = _diagnose_one(folder, params)
            named = [c for c in result.causes if c in CAUSES]
            truth_label, named_label = _label(expected), _label(result.causes)
            row = confusion.setdefault(truth_label, {})
            row[named_label] = row.get(named_label, 0) + 1
            sets.append({
                "seed": seed, "truth": generator.describe(truth),
                "causes": list(result.causes), "correct": sorted(named) == sorted(expected),
                "one_named": bool(set(named) & set(expected)) or not expected,
                "first_correct": (named[:1] == list(expected[:1])),
                "gain": float(result.gain), "seconds": seconds,
                "tests": len(data.tests), "samples": sum(len(t.time_s) for t in data.tests),
            })
            if progress is not None:
                progress(f"seed {seed}: truth {truth_label}, named {named_label}, "
                         f"gain {result.gain:.2f}, {seconds:.1f} s")
        if kind == "single":
            relaxation = _relaxation_entry(Path(scratch), seeds[0], params)
            if progress is not None:
                progress(f"relaxation set: named {_label(relaxation['causes'])}, gain "
                         f"{relaxation['gain']:.2f}, {relaxation['seconds']:.1f} s")
    report = _summary(sets, confusion, relaxation, kind, params.workers, seeds)
    return {**report, "including": including, "protocol": protocol}


def _summary(sets: list[dict[str, Any]], confusion: dict[str, dict[str, int]],
             relaxation: dict[str, Any] | None, kind: str, workers: int,
             seeds: Sequence[int]) -> dict[str, Any]:
    """The bench's JSON: sets, entries, targets, the confusion table."""
    times = [s["seconds"] for s in sets]
    count = len(sets)
    correct = sum(s["correct"] for s in sets)
    one = sum(s["one_named"] for s in sets)
    time_entries, time_targets = time_summary(times, TARGET_SECONDS_MEDIAN,
                                              TARGET_SECONDS_PER_SET)
    entries = {
        **time_entries,
        "tests_per_set": {"value": statistics.median(s["tests"] for s in sets),
                          "unit": "tests"},
        "samples_per_set": {"value": statistics.median(s["samples"] for s in sets),
                            "unit": "samples"},
        "correct": {"value": correct / count, "unit": "fraction", "count": correct,
                    "of": count},
        "first_cause_correct": {"value": sum(s["first_correct"] for s in sets) / count,
                                "unit": "fraction", "of": count},
    }
    targets = {
        **time_targets,
        "correct": {"value": correct / count, "target": TARGET_CORRECT[kind],
                    "unit": "fraction", "pass": correct / count >= TARGET_CORRECT[kind]},
    }
    if kind == "triples":
        entries["one_named"] = {"value": one / count, "unit": "fraction", "count": one,
                                "of": count}
    if kind == "pairs":
        entries["one_of_pair_named"] = {"value": one / count, "unit": "fraction",
                                        "count": one, "of": count}
        targets["one_of_pair_named"] = {"value": one / count, "target": TARGET_ONE_OF_PAIR,
                                        "unit": "fraction",
                                        "pass": one / count >= TARGET_ONE_OF_PAIR}
    if relaxation is not None:
        entries["relaxation_set_seconds"] = {"value": relaxation["seconds"], "unit": "s"}
        entries["relaxation_set_gain"] = {"value": relaxation["gain"], "unit": "fraction"}
        targets["relaxation_set_time"] = {
            "value": relaxation["seconds"], "target": TARGET_RELAXATION_SECONDS, "unit": "s",
            "pass": relaxation["seconds"] <= TARGET_RELAXATION_SECONDS}
        targets["relaxation_set_named"] = {
            "value": relaxation["gain"], "target": TARGET_RELAXATION_GAIN, "unit": "gain",
            "pass": relaxation["first_correct"]
            and relaxation["gain"] >= TARGET_RELAXATION_GAIN}
    return {"suite": "diagnose", "kind": kind, "workers": workers, "seeds": list(seeds),
            "sets": sets, "relaxation_set": relaxation, "entries": entries,
            "confusion": confusion, "markdown": confusion_markdown(confusion),
            "targets": targets}
