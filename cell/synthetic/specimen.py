"""Synthetic measurement sets: the one generator of the project's seeded, noisy test sets.

A set is drawn from a stated truth model (nominal stress ``P``, Pa, against nominal strain
``e = displacement / height``; force ``= P * area``), a protocol of
:class:`~cell.measure.protocols.TestPlan` (the displacement path the machine drives, linear
between knots, and the sample times), and seeded noise; it is written in the measured-data
format (``specimen.toml``, ``tests.csv``). The pieces, used by every synthetic set:

- :func:`~cell.synthetic.truth.qlv_stress_pa`: quasi-linear viscoelasticity over any elastic
  law (:mod:`cell.synthetic.truth`, the laws of the hidden effects);
- :class:`~cell.measure.protocols.TestPlan` and its shapes (:mod:`cell.measure.protocols`),
  and :func:`~cell.measure.protocols.true_force_n`: the truth's force along a plan (optionally
  on a finer grid);
- :func:`measure`: force and displacement noise, drawn test by test;
- :func:`csv_text` and :func:`specimen_toml`: the files' text; :func:`write_set` writes them.

Hidden-effect sets (what the diagnosis is tested on): :func:`write_hidden_effect_set` draws,
from one seed, a specimen, a linear isotropic baseline, effects of the diagnosis catalogue
(none, one or a combination) with random magnitudes (:mod:`cell.synthetic.truth`), a ten-test
protocol and the noise, writes the set and returns the truth. The files hold no truth
parameter. The diagnosis (:mod:`cell.diagnosis.specimen.diagnosis`) never imports this module: it is
the answer key (an import-rule test holds it to that). The protocol (ten tests, 150 to 400 samples
each, some unevenly sampled) shows every effect: ramps in tension at three angles and in
compression at two, a ramp ten times faster, two relaxation holds at different strains,
load/unload cycles in tension and in compression. :func:`write_relaxation_set` writes a
relaxation-only set shaped like published muscle tests. The example set
(``scripts/make_example_set.py``) is another truth on the same pieces.

Example:
    >>> truth = write_hidden_effect_set(Path("out/hidden-7"), seed=7)
    >>> truth.effect in EFFECTS, sorted(p.name for p in Path("out/hidden-7").iterdir())
    (True, ['specimen.toml', 'tests.csv'])
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np

from cell.diagnosis.specimen.causes import UNIAXIAL_CAUSES
from cell.errors import MeasurementError
from cell.measure.protocols import TestPlan, lab_protocol, true_force_n
from cell.outputs import write_atomic
from cell.synthetic.truth import check_effects, draw_magnitudes, truth_stress_pa

EFFECTS: tuple[str | None, ...] = (*UNIAXIAL_CAUSES, None)
"""The single effects a set can hide: the causes of the catalogue, and None (baseline alone)."""
Effects = str | Sequence[str] | Literal["random"] | None
"""What :func:`write_hidden_effect_set` hides: a cause, several, none, or one drawn."""

DENSITY_KG_M3 = 1060.0
ASPECT_SPREAD = 0.03
"""Each edge of the (near-cubic) hidden-effect specimen is the drawn edge times 1 +- up to this."""
DISPLACEMENT_NOISE_M = 0.2e-6
"""Displacement noise of the hidden-effect sets, m (standard deviation)."""
_HEADER = "test_id,mode,angle_deg,time_s,displacement_m,force_N"
_HIDDEN_HEADER = (
    "# SYNTHETIC measurement set: no tissue was tested. Drawn from a seeded truth model with\n"
    "# noise by the project's hidden-effect generator, to test the diagnosis against it;\n"
    "# the truth is kept out of these files.")

@dataclass(frozen=True)
class Noise:
    """The measurement noise of a set.

    Attributes:
        force_n: standard deviation of the force noise, N.
        displacement_m: standard deviation of the displacement noise, m.
        offset_n: a constant added to every force (a load cell zeroed off), N.
    """

    force_n: float
    displacement_m: float
    offset_n: float = 0.0


def measure(plans: Sequence[TestPlan], forces_n: Sequence[np.ndarray], height_m: float,
            noise: Noise, rng: np.random.Generator) -> list[tuple[np.ndarray, np.ndarray]]:
    """(displacement_m, force_N) as measured, per test: truth plus noise.

    The noise is drawn test by test in the order of ``plans``: force noise, then displacement
    noise. The first displacement of every test is exactly 0 (the machine's zero).
    """
    measured = []
    for plan, force in zip(plans, forces_n, strict=True):
        noisy = force + noise.offset_n + rng.normal(0.0, noise.force_n, force.shape)
        displacement = plan.strain() * height_m + rng.normal(0.0, noise.displacement_m,
                                                             force.shape)
        displacement[0] = 0.0
        measured.append((displacement, noisy))
    return measured


@dataclass(frozen=True)
class Digits:
    """Decimals written: per column of ``tests.csv``, and for ``size_m`` in ``specimen.toml``."""

    time_s: int
    displacement_m: int
    force_n: int
    size_m: int


def csv_text(plans: Sequence[TestPlan], measured: Sequence[tuple[np.ndarray, np.ndarray]],
             digits: Digits, specimens: Sequence[str] = ()) -> str:
    """The ``tests.csv`` text: a header, then one fixed-point row per sample; with
    ``specimens`` (one name per plan), a ``specimen`` column."""
    rows = [_HEADER + (",specimen" if specimens else "")]
    names = [f",{name}" for name in specimens] or [""] * len(plans)
    for plan, (displacement, force), name in zip(plans, measured, names, strict=True):
        rows += [f"{plan.test_id},{plan.mode},{plan.angle_deg:g},{t:.{digits.time_s}f},"
                 f"{d:.{digits.displacement_m}f},{f:.{digits.force_n}f}{name}"
                 for t, d, f in zip(plan.time_s, displacement, force, strict=True)]
    return "\n".join(rows) + "\n"


def specimen_toml(header: str, name: str, size_m: Sequence[float], rig: dict[str, str | float],
                  digits: Digits) -> str:
    """The ``specimen.toml`` text: ``header`` (comment lines), then the tables.

    ``rig`` values are written as TOML strings or numbers, in their order.
    """
    size = ", ".join(f"{s:.{digits.size_m}f}" for s in size_m)
    rig_lines = [f'{key} = "{value}"' if isinstance(value, str) else f"{key} = {value!r}"
                 for key, value in rig.items()]
    return "\n".join([
        header, "", "[specimen]", f'name = "{name}"', f"size_m = [{size}]",
        f"density_kg_m3 = {DENSITY_KG_M3:.1f}",
        "# The load axis is specimen z; the fibres lie in the x-z plane at each test's angle_deg.",
        "", "[rig]", *rig_lines, ""])


def write_set(folder: Path, specimen_text: str, tests_text: str) -> None:
    """Write ``specimen.toml`` and ``tests.csv`` in ``folder`` (created), each atomically."""
    write_atomic(Path(folder) / "specimen.toml", specimen_text)
    write_atomic(Path(folder) / "tests.csv", tests_text)


@dataclass(frozen=True)
class HiddenEffect:
    """The truth behind one hidden-effect set.

    Attributes:
        effects: the causes switched on (names of the catalogue, in its order); none for the
            baseline alone.
        seed: the seed everything was drawn from.
        magnitudes: the drawn parameters: ``young_pa`` (baseline E) always, plus each
            effect's own (:func:`cell.synthetic.truth.draw_magnitudes`).
        noise_n: standard deviation of the force noise, N.
        specimen_factors: per test, the factor of its specimen on the material (empty for
            one specimen throughout: a set without :class:`Repeats`).
    """

    effects: tuple[str, ...]
    seed: int
    magnitudes: dict[str, float]
    noise_n: float
    specimen_factors: tuple[float, ...] = ()

    @property
    def effect(self) -> str | None:
        """The one effect of a single-effect set (None for none).

        Raises:
            MeasurementError: the set hides more than one.
        """
        if len(self.effects) > 1:
            raise MeasurementError(None, "effect", f"the set hides {self.effects}")
        return self.effects[0] if self.effects else None


def _times(rng: np.random.Generator, knots: list[float], counts: list[int],
           uneven: bool = False) -> np.ndarray:
    """Sample times: ``counts[i]`` intervals on segment i between ``knots``, knots included.

    Uneven segments get jittered interior samples. Times are rounded to 0.1 ms (as written).
    """
    parts = []
    for start, end, count in zip(knots[:-1], knots[1:], counts, strict=True):
        fraction = np.linspace(0.0, 1.0, count + 1)[:-1]
        if uneven:
            fraction[1:] += rng.uniform(-0.4, 0.4, count - 1) / count
        parts.append(start + (end - start) * fraction)
    return np.round(np.append(np.concatenate(parts), knots[-1]), 4)


def _protocol(rng: np.random.Generator) -> list[TestPlan]:
    """The ten tests of a hidden-effect set: ramps, a fast ramp, relaxation holds, cycles."""
    rate = rng.uniform(0.005, 0.02)  # base strain rate, 1/s
    tension = rng.uniform(0.10, 0.18)
    compression = rng.uniform(-0.25, -0.15)
    mid = float(np.round(rng.uniform(30.0, 60.0)))
    tests: list[TestPlan] = []

    def drawn_ramp(test_id: str, mode: str, angle: float, peak: float, speed: float,
                   uneven: bool = False) -> None:
        end = float(np.round(abs(peak) / speed, 4))
        time = _times(rng, [0.0, end], [int(rng.integers(150, 300))], uneven)
        tests.append(TestPlan(test_id, mode, angle, (0.0, end), (0.0, peak), time))

    drawn_ramp("t00", "tension", 0.0, tension, rate)
    drawn_ramp(f"t{mid:02.0f}", "tension", mid, tension, rate, uneven=True)
    drawn_ramp("t90", "tension", 90.0, tension, rate)
    drawn_ramp("c00", "compression", 0.0, compression, rate)
    drawn_ramp("c90", "compression", 90.0, compression, rate, uneven=True)
    drawn_ramp("t00-fast", "tension", 0.0, tension, 10.0 * rate)
    hold_strain, hold_s = rng.uniform(0.08, 0.12), float(np.round(rng.uniform(60.0, 120.0)))
    # Holds at two strains, so that a relaxed fraction that depends on the strain shows.
    for angle, held in ((0.0, 0.6 * hold_strain), (90.0, 1.5 * hold_strain)):
        # Ramp in 2 s, then a hold sampled densely at first, sparsely later (uneven).
        hold = 2.0 + np.geomspace(0.05, hold_s, int(rng.integers(150, 250)))
        time = np.round(np.concatenate([np.linspace(0.0, 2.0, 41), hold]), 4)
        tests.append(TestPlan(f"r{angle:02.0f}", "relaxation", angle, (0.0, 2.0),
                              (0.0, held), time))
    for test_id, angle, peak in (("y00", 0.0, rng.uniform(0.10, 0.13)),
                                 ("y90c", 90.0, rng.uniform(-0.15, -0.10))):
        leg = float(np.round(abs(peak) / rate, 4))
        knots = [leg * k for k in range(7)]
        time = _times(rng, knots, [int(rng.integers(30, 60))] * 6)
        tests.append(TestPlan(test_id, "cyclic", angle, tuple(knots),
                              (0.0, peak) * 3 + (0.0,), time))
    return tests


HIDDEN_DIGITS = Digits(time_s=4, displacement_m=10, force_n=8, size_m=5)
"""Decimals of the hidden-effect sets' files (and of a test added to one)."""


@dataclass(frozen=True)
class Repeats:
    """Tests repeated under equal conditions, each on another specimen: the first
    ``conditions`` tests of the protocol, ``count`` times each (ids ``<id>-<k>``), every test's
    force times its specimen's factor ``exp(u)``, ``u ~ N(0, spread_sd**2)`` (a factor on the
    whole material: every term of the truth's stress scales with its modulus). With
    ``named``, repeat k is one specimen ``S<k+1>`` that runs every kept test (one factor for
    all of them), written in the ``specimen`` column.

    Attributes:
        conditions: tests of the protocol kept (1 to 10).
        count: repeats of each (at least 1): with ``named``, the specimens.
        spread_sd: standard deviation of the log factor (0: one material throughout).
        named: whether each repeat is a named specimen running every condition.

    Example:
        >>> Repeats(5, 3, 0.2).count
        3
    """

    conditions: int = 10
    count: int = 3
    spread_sd: float = 0.0
    named: bool = False

    @property
    def specimen_ids(self) -> tuple[str, ...]:
        """Per repeated test (in :meth:`apply`'s order), its specimen's name; none unless
        ``named``."""
        if not self.named:
            return ()
        return tuple(f"S{k + 1}" for _ in range(self.conditions) for k in range(self.count))

    def __post_init__(self) -> None:
        if not (1 <= self.conditions <= 10 and self.count >= 1 and self.spread_sd >= 0.0):
            raise MeasurementError(None, "repeats", f"1 to 10 conditions, at least one "
                                   f"repeat and a spread >= 0, got {self}")

    def apply(self, plans: list[TestPlan], forces: list[np.ndarray], rng: np.random.Generator
              ) -> tuple[list[TestPlan], list[np.ndarray], tuple[float, ...]]:
        """The repeated plans, their forces and the specimens' factors."""
        kept = range(self.conditions)
        factors = np.exp(rng.normal(0.0, self.spread_sd, self.conditions * self.count))
        if self.named:
            factors = np.tile(factors[:self.count], self.conditions)
        repeated = [replace(plans[i], test_id=f"{plans[i].test_id}-{k}")
                    for i in kept for k in range(self.count)]
        scaled = [forces[i] * factors[j] for j, i in
                  enumerate(i for i in kept for _ in range(self.count))]
        return repeated, scaled, tuple(float(f) for f in factors)


def _pick(rng: np.random.Generator, effect: Effects) -> tuple[str, ...]:
    """The hidden effects: drawn when ``effect`` is ``"random"`` (the draw is made either way,
    so that the later draws do not depend on it), else ``effect`` checked."""
    index = int(rng.integers(len(EFFECTS)))
    if effect == "random":
        effect = EFFECTS[index]
    if effect is None:
        return ()
    return check_effects((effect,) if isinstance(effect, str) else tuple(effect))


def write_hidden_effect_set(folder: Path, seed: int, effect: Effects = "random",
                            strength: float = 1.0, repeats: Repeats | None = None,
                            protocol: Literal["hidden", "lab"] = "hidden") -> HiddenEffect:
    """Draw a set from ``seed`` with ``effect`` hidden in it, write it in ``folder``, return it.

    ``effect`` is a cause, several (a tuple: a combination), None, or ``"random"`` (one of
    :data:`EFFECTS`); ``strength`` in (0, 1] scales every effect towards none
    (:func:`cell.synthetic.truth.draw_magnitudes`); ``repeats`` repeats tests of the protocol,
    each repeat another specimen (:class:`Repeats`). ``protocol`` ``"lab"`` draws another
    generator's sets: :func:`~cell.measure.protocols.lab_protocol`'s tests, force noise 0.3 to
    1.2 % of the peak and a load cell's offset (when hidden) of 6 to 12 % of it, drawn from a
    stream of their own. Everything else comes from
    ``np.random.default_rng(seed)`` (the specimens' factors from their own stream); the draws
    other than the effects' own parameters do not depend on the effects, nor on the spread.
    Writes ``specimen.toml`` and ``tests.csv`` (creating ``folder``).

    Raises:
        MeasurementError: an unknown effect, one twice, both viscoelasticities, a
            ``strength`` outside (0, 1], or repeats out of range.
    """
    if not 0.0 < strength <= 1.0:
        raise MeasurementError(None, "strength", f"must be in (0, 1], got {strength}")
    rng = np.random.default_rng(seed)
    effects = _pick(rng, effect)
    edge = rng.uniform(0.008, 0.012)
    size = np.round(edge * (1.0 + ASPECT_SPREAD * rng.uniform(-1.0, 1.0, 3)), 5)
    area, height = float(size[0] * size[1]), float(size[2])
    tests = _protocol(rng) if protocol == "hidden" else lab_protocol(rng)
    magnitudes = draw_magnitudes(rng, effects, strength)
    lab = np.random.default_rng([seed, 2])
    if protocol == "lab" and "offset_fraction" in magnitudes:
        magnitudes["offset_fraction"] = (strength * lab.uniform(0.06, 0.12)
                                         * np.sign(magnitudes["offset_fraction"]))

    def stress(time_s: np.ndarray, strain: np.ndarray, angle_deg: float) -> np.ndarray:
        return truth_stress_pa(time_s, strain, angle_deg, magnitudes)

    forces = [true_force_n(test, stress, area) for test in tests]
    factors: tuple[float, ...] = ()
    if repeats is not None:
        tests, forces, factors = repeats.apply(tests, forces, np.random.default_rng([seed, 1]))
        magnitudes["specimen_log_sd"] = repeats.spread_sd
    peak = max(float(np.abs(f).max()) for f in forces)
    offset = magnitudes.get("offset_fraction", 0.0) * peak
    noise_n = (rng.uniform(0.003, 0.015) if protocol == "hidden"
               else lab.uniform(0.003, 0.012)) * peak
    measured = measure(tests, forces, height, Noise(noise_n, DISPLACEMENT_NOISE_M, offset), rng)
    write_set(folder,
              specimen_toml(_HIDDEN_HEADER, f"hidden-effect-{seed} (synthetic)", size,
                            {"machine": "uniaxial tester (synthetic)"}, HIDDEN_DIGITS),
              csv_text(tests, measured, HIDDEN_DIGITS,
                       repeats.specimen_ids if repeats is not None else ()))
    return HiddenEffect(effects, seed, magnitudes, float(noise_n), factors)


def write_relaxation_set(folder: Path, seed: int) -> HiddenEffect:
    """A relaxation-only set shaped like published muscle tests, its relaxation non-linear.

    Twelve ramp-and-hold compressions: to 10, 20 and 30 % strain, at 0.5 and 5 %/s, along
    and across the fibres; each ramp sampled 10 times, then a 300 s hold sampled every 7.5 s
    (50 samples a test). The truth: linear isotropic springs (E drawn) whose relaxed fraction
    falls from 75 % at 10 % strain to 50 % at 30 % (muscle in compression), two relaxation
    times drawn as :func:`write_hidden_effect_set` does; force noise 0.5 % of the peak.
    """
    rng = np.random.default_rng(seed)
    magnitudes = draw_magnitudes(rng, ("nonlinear_viscoelasticity",), 1.0)
    magnitudes.update(relaxed=0.75, relaxed_per_strain=-1.25)
    size = (0.010, 0.010, 0.010)
    tests = []
    for strain in (-0.10, -0.20, -0.30):
        for rate in (0.005, 0.05):
            for angle in (0.0, 90.0):
                end = abs(strain) / rate
                time = np.round(np.concatenate([np.linspace(0.0, end, 10),
                                                end + np.linspace(7.5, 300.0, 40)]), 4)
                tests.append(TestPlan(f"r{angle:02.0f}-{abs(strain) * 100:.0f}-{rate * 1e3:g}",
                                      "relaxation", angle, (0.0, end), (0.0, strain), time))

    def stress(time_s: np.ndarray, strain: np.ndarray, angle_deg: float) -> np.ndarray:
        return truth_stress_pa(time_s, strain, angle_deg, magnitudes)

    # The machine drives the displacement linearly between samples far apart: the truth
    # follows that path on a finer grid.
    forces = [true_force_n(test, stress, size[0] * size[1], substeps=20) for test in tests]
    noise_n = 0.005 * max(float(np.abs(f).max()) for f in forces)
    measured = measure(tests, forces, size[2], Noise(noise_n, DISPLACEMENT_NOISE_M), rng)
    write_set(folder,
              specimen_toml(_HIDDEN_HEADER, f"relaxation-{seed} (synthetic)", size,
                            {"machine": "uniaxial tester (synthetic)"}, HIDDEN_DIGITS),
              csv_text(tests, measured, HIDDEN_DIGITS))
    return HiddenEffect(("nonlinear_viscoelasticity",), seed, magnitudes, float(noise_n))


def describe(truth: HiddenEffect) -> dict[str, Any]:
    """The truth as plain JSON-able values (for reports)."""
    return {"effects": list(truth.effects), "seed": truth.seed,
            "magnitudes": {k: float(v) for k, v in truth.magnitudes.items()},
            "noise_n": truth.noise_n,
            "specimen_factors": [float(f) for f in truth.specimen_factors]}
