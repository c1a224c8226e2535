"""``musclecell bench diagnose --suggest``: does the suggested next test tell the truth apart?

Each set is a hidden-effect set (:mod:`cell.synthetic.specimen`, seeds no test uses) with the
tests that would show its effect taken out: one kind of missing evidence per set, in turn
(:data:`MISSING`):

- ``compression``: no test in compression, an asymmetry hidden;
- ``angles``: every test along the fibres, an anisotropy hidden;
- ``holds``: no ramp-and-hold, no fast ramp and no cycle, a viscoelasticity hidden (a ramp at
  one rate that softens could yield as well);
- ``cycles``: the same tests taken out, a plasticity hidden (a ramp that softens could relax
  as well).

The set is diagnosed and a test suggested (:func:`cell.diagnosis.specimen.suggest.suggest`); the
test is then run on the truth (the generator's law, its noise drawn as the set's), added to the set,
and the set diagnosed again; and, for comparison, a candidate test drawn at random is added to
the same set instead. A set counts when the diagnosis then names exactly the hidden effect
(``unexplained`` and ``specimen_variability`` aside).

Targets: the truth named after the suggested test in >= 80 % of the sets and in
more of them than after the random test; the suggestion (rivals, candidate tests, scores)
within 60 s.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cell.bench.diagnose import check_request
from cell.diagnosis.specimen.nexttests import CandidateTest
from cell.errors import MeasurementError
from cell.io import read_text
from cell.outputs import write_atomic
from cell.synthetic import specimen as generator

#: The first seed of the suggest bench; the tests use seeds below 10 000.
FIRST_SEED = 140_000
TARGET_NAMED = 0.8
TARGET_SUGGEST_SECONDS = 60.0


@dataclass(frozen=True)
class Missing:
    """One kind of missing evidence: the effect it hides and the tests it takes out.

    Attributes:
        effect: the hidden effect.
        modes: the modes taken out.
        negative: whether tests in compression (any negative strain) are taken out.
        oblique: whether tests at an angle other than 0 are taken out.
        fast: whether the fast ramp (``-fast`` in the generator's ids) is taken out.
    """

    effect: str
    modes: tuple[str, ...] = ()
    negative: bool = False
    oblique: bool = False
    fast: bool = False

    def drops(self, mode: str, angle_deg: float, least_strain: float, test_id: str) -> bool:
        """Whether a test of the generator's protocol is taken out."""
        return (mode in self.modes or (self.negative and least_strain < 0.0)
                or (self.oblique and angle_deg != 0.0)
                or (self.fast and test_id.endswith("-fast")))


MISSING: dict[str, Missing] = {
    "compression": Missing("tension_compression_asymmetry", negative=True),
    "angles": Missing("anisotropy", oblique=True),
    "holds": Missing("viscoelasticity", modes=("relaxation", "cyclic"), fast=True),
    "cycles": Missing("plasticity", modes=("relaxation", "cyclic"), fast=True),
}


def bench_seeds(count: int) -> list[int]:
    """The seeds of ``count`` suggest-bench sets."""
    return [FIRST_SEED + i for i in range(count)]


def missing_kind(seed: int) -> str:
    """The kind of missing evidence of the set of ``seed``, in turn."""
    return tuple(MISSING)[seed % len(MISSING)]


def write_ambiguous_set(folder: Path, seed: int) -> generator.HiddenEffect:
    """The hidden-effect set of ``seed`` with the tests of its missing evidence taken out."""
    from cell.measure.specimens import load_measurement_set

    missing = MISSING[missing_kind(seed)]
    truth = generator.write_hidden_effect_set(folder, seed, missing.effect)
    data = load_measurement_set(folder)
    dropped = {t.test_id for t in data.tests
               if missing.drops(t.mode, t.angle_deg, float(t.displacement_m.min()), t.test_id)}
    lines = read_text(folder / "tests.csv", "csv", MeasurementError).splitlines(keepends=True)
    write_atomic(folder / "tests.csv",
                 "".join(line for line in lines if line.split(",", 1)[0] not in dropped))
    return truth


def add_test(folder: Path, truth: generator.HiddenEffect, test: CandidateTest,
             test_id: str, rng: np.random.Generator) -> None:
    """Run ``test`` on the truth of the set in ``folder`` (noise as the set's) and add it."""
    from cell.measure.protocols import true_force_n
    from cell.measure.specimens import load_specimen
    from cell.synthetic.truth import truth_stress_pa

    specimen = load_specimen(folder / "specimen.toml")
    plan = test.plan(test_id)

    def stress(time_s: np.ndarray, strain: np.ndarray, angle_deg: float) -> np.ndarray:
        return truth_stress_pa(time_s, strain, angle_deg, truth.magnitudes)

    force = true_force_n(plan, stress, specimen.area_m2)
    measured = generator.measure(
        [plan], [force], specimen.size_m[2],
        generator.Noise(truth.noise_n, generator.DISPLACEMENT_NOISE_M), rng)
    rows = generator.csv_text([plan], measured, generator.HIDDEN_DIGITS).split("\n", 1)[1]
    write_atomic(folder / "tests.csv",
                 read_text(folder / "tests.csv", "csv", MeasurementError) + rows)


def _named(result: Any, truth: generator.HiddenEffect) -> bool:
    from cell.diagnosis.specimen.causes import CAUSES

    return sorted(c for c in result.causes if c in CAUSES) == sorted(truth.effects)


def _one_set(scratch: Path, seed: int, params: Any) -> dict[str, Any]:
    """Diagnose the ambiguous set of ``seed``, suggest, and diagnose again with the suggested
    and with a random candidate test added."""
    import shutil

    from cell.diagnosis.specimen.diagnosis import diagnose
    from cell.diagnosis.specimen.nexttests import candidate_tests
    from cell.diagnosis.specimen.suggest import suggest
    from cell.measure.specimens import load_measurement_set

    base = scratch / f"set-{seed}"
    truth = write_ambiguous_set(base, seed)
    data = load_measurement_set(base)
    start = time.perf_counter()
    first = diagnose(data, params)
    diagnosed = time.perf_counter() - start
    suggestion = suggest(first)
    suggested_s = time.perf_counter() - start - diagnosed
    rng = np.random.default_rng([seed, 2])
    candidates = candidate_tests(data)
    picks = {"suggested": suggestion.test or candidates[0],
             "random": candidates[int(rng.integers(len(candidates)))]}
    entry: dict[str, Any] = {
        "seed": seed, "missing": missing_kind(seed), "truth": generator.describe(truth),
        "tests": len(data.tests), "causes_before": list(first.causes),
        "named_before": _named(first, truth), "ambiguous": suggestion.ambiguous,
        "rivals": [r.name for r in suggestion.rivals],
        "diagnosis_seconds": diagnosed, "suggest_seconds": suggested_s}
    for label, test in picks.items():
        folder = scratch / f"set-{seed}-{label}"
        shutil.copytree(base, folder)
        add_test(folder, truth, test, "next", np.random.default_rng([seed, 3]))
        again = diagnose(load_measurement_set(folder), params)
        entry[label] = {"test": test.to_json(), "causes": list(again.causes),
                        "named": _named(again, truth)}
    entry["suggested"]["predicted_difference_N"] = suggestion.difference_n
    entry["suggested"]["over_scatter"] = suggestion.over_scatter
    return entry


def run_suggest_bench(seeds: Sequence[int], workers: int | None = None,
                      progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """The suggest bench on one ambiguous set per seed (module docstring): per set the
    diagnoses before and after, and the entries and targets.

    Raises:
        MeasurementError: no seed.
    """
    check_request(seeds, "suggest", ("suggest",))
    from cell.diagnosis.engine.settings import DiagnosisParams

    params = DiagnosisParams() if workers is None else DiagnosisParams(workers=workers)
    sets = []
    with tempfile.TemporaryDirectory(prefix="bench-suggest-") as scratch:
        for seed in seeds:
            entry = _one_set(Path(scratch), seed, params)
            sets.append(entry)
            if progress is not None:
                progress(f"seed {seed}: no {entry['missing']}, truth "
                         f"{'+'.join(entry['truth']['effects'])}; named before "
                         f"{entry['named_before']}, after the suggested "
                         f"({entry['suggested']['test']['description']}) "
                         f"{entry['suggested']['named']}, after a random one "
                         f"{entry['random']['named']}; suggest {entry['suggest_seconds']:.1f} s")
    return _summary(sets, params.workers, seeds)


def _summary(sets: list[dict[str, Any]], workers: int, seeds: Sequence[int]) -> dict[str, Any]:
    """The bench's JSON: sets, entries, targets and a Markdown table."""
    count = len(sets)
    rate = {label: sum(s[label]["named"] for s in sets) / count
            for label in ("suggested", "random")}
    before = sum(s["named_before"] for s in sets) / count
    # What a user waits for: `diagnose --suggest` diagnoses the set, then suggests.
    whole = [s["diagnosis_seconds"] + s["suggest_seconds"] for s in sets]
    slowest = max(whole)
    entries = {
        "named_before": {"value": before, "unit": "fraction", "of": count},
        "named_after_suggested": {"value": rate["suggested"], "unit": "fraction", "of": count},
        "named_after_random": {"value": rate["random"], "unit": "fraction", "of": count},
        "suggest_seconds_median": {"value": statistics.median(s["suggest_seconds"]
                                                              for s in sets), "unit": "s"},
        "suggest_seconds_max": {"value": max(s["suggest_seconds"] for s in sets), "unit": "s"},
        "diagnose_suggest_seconds_median": {"value": statistics.median(whole), "unit": "s"},
        "diagnose_suggest_seconds_max": {"value": slowest, "unit": "s"},
        "kinds_of_missing_evidence": {"value": len({s["missing"] for s in sets}),
                                      "unit": "kinds"},
    }
    targets = {
        "named_after_suggested": {"value": rate["suggested"], "target": TARGET_NAMED,
                                  "unit": "fraction", "pass": rate["suggested"] >= TARGET_NAMED},
        "suggested_beats_random": {"value": rate["suggested"] - rate["random"],
                                   "target": 0.0, "unit": "fraction",
                                   "pass": rate["suggested"] > rate["random"]},
        "suggest_time": {"value": slowest, "target": TARGET_SUGGEST_SECONDS, "unit": "s",
                         "pass": slowest <= TARGET_SUGGEST_SECONDS},
    }
    lines = ["| missing | truth | before | suggested test | after it | after a random test |",
             "| --- | --- | --- | --- | --- | --- |"]
    lines += [f"| {s['missing']} | {'+'.join(s['truth']['effects'])} | "
              f"{'+'.join(s['causes_before']) or 'none'} | "
              f"{s['suggested']['test']['description']} | "
              f"{'+'.join(s['suggested']['causes']) or 'none'} | "
              f"{'+'.join(s['random']['causes']) or 'none'} |" for s in sets]
    return {"suite": "diagnose", "kind": "suggest", "workers": workers, "seeds": list(seeds),
            "sets": sets, "entries": entries, "targets": targets,
            "markdown": "\n".join(lines) + "\n"}
