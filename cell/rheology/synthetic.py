"""Synthetic measurement sets: the one generator of the project's seeded, noisy test sets.

A set is drawn from a stated truth model (nominal stress ``P``, Pa, against nominal strain
``e = displacement / height``; force ``= P * area``), a protocol of :class:`TestPlan` (the
displacement path the machine drives, linear between knots, and the sample times), and
seeded noise; it is written in the measured-data format (``specimen.toml``, ``tests.csv``).
The pieces, used by every synthetic set:

- :func:`qlv_stress_pa`: quasi-linear viscoelasticity over any elastic law;
- :func:`true_force_n`: the truth's force along a plan (optionally on a finer grid);
- :func:`measure`: force and displacement noise, drawn test by test;
- :func:`csv_text` and :func:`specimen_toml`: the files' text; :func:`write_set` writes them.

Hidden-effect sets (what the diagnosis is tested on): :func:`write_hidden_effect_set` draws,
from one seed, a specimen, a linear isotropic baseline, at most one effect of the diagnosis
catalogue with random magnitudes (:func:`truth_stress_pa`), a ten-test protocol and the noise,
writes the set and returns the truth. The files hold no truth parameter. The diagnosis
(:mod:`cell.rheology.diagnosis`) never imports this module: it is the answer key (an
import-rule test holds it to that). The protocol (ten tests, 150 to 400 samples each, some
unevenly sampled) shows every effect: ramps in tension at three angles and in compression at
two, a ramp ten times faster, two relaxation holds, load/unload cycles in tension and in
compression. The example set (``scripts/make_example_set.py``) is another truth on the same
pieces.

Example:
    >>> truth = write_hidden_effect_set(Path("out/hidden-7"), seed=7)
    >>> truth.effect in EFFECTS, sorted(p.name for p in Path("out/hidden-7").iterdir())
    (True, ['specimen.toml', 'tests.csv'])
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from cell.errors import MeasurementError
from cell.io import write_atomic
from cell.rheology.causes import CAUSES

EFFECTS: tuple[str | None, ...] = (*CAUSES, None)
"""The effects one set can hide: the six causes of the catalogue, and None (baseline alone)."""

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

StressLaw = Callable[[np.ndarray, np.ndarray, float], np.ndarray]
"""A truth model: nominal stress, Pa, from (time_s, strain, angle_deg) at one test's samples."""


@dataclass(frozen=True, eq=False)
class TestPlan:
    """One test of a protocol: the displacement path (strain at knots, linear between them,
    held after the last) and the sample times.

    Attributes:
        test_id, mode, angle_deg: as written in ``tests.csv`` (angle to the fibres, degrees).
        knots_s: (k,) times of the path's knots, s, increasing.
        knots_strain: (k,) nominal strain at the knots.
        time_s: (n,) sample times, s.
        description: one line saying what the test is (for a set's header).

    Example:
        >>> plan = ramp("t00", "tension", 0.0, 0.1, 0.01, samples=3)
        >>> plan.time_s.tolist(), plan.strain().tolist(), plan.description
        ([0.0, 5.0, 10.0], [0.0, 0.05, 0.1], 'tension to +0.10 at 1 %/s')
    """

    __test__ = False  # not a pytest test class, despite its name

    test_id: str
    mode: str
    angle_deg: float
    knots_s: tuple[float, ...]
    knots_strain: tuple[float, ...]
    time_s: np.ndarray
    description: str = ""

    def strain(self) -> np.ndarray:
        """The noise-free nominal strain at the sample times."""
        return np.interp(self.time_s, self.knots_s, self.knots_strain)


def ramp(test_id: str, mode: str, angle_deg: float, strain: float, rate_per_s: float,
         samples: int) -> TestPlan:
    """A ramp from 0 to ``strain`` at constant ``rate_per_s`` (1/s), evenly sampled."""
    end = abs(strain) / rate_per_s
    return TestPlan(test_id, mode, angle_deg, (0.0, end), (0.0, strain),
                    np.linspace(0.0, end, samples),
                    f"{mode} to {strain:+.2f} at {rate_per_s * 100:g} %/s")


def relaxation(test_id: str, angle_deg: float, strain: float, rate_per_s: float,
               hold_s: float, ramp_samples: int, hold_samples: int) -> TestPlan:
    """A ramp to ``strain``, then a hold sampled on a logarithmic clock (0.2 s to ``hold_s``)."""
    end = abs(strain) / rate_per_s
    time = np.concatenate([np.linspace(0.0, end, ramp_samples),
                           end + np.geomspace(0.2, hold_s, hold_samples)])
    return TestPlan(test_id, "relaxation", angle_deg, (0.0, end, end + hold_s),
                    (0.0, strain, strain), time,
                    f"ramp to {strain:+.2f} at {rate_per_s * 100:g} %/s, "
                    f"then a {hold_s:.0f} s hold")


def cyclic(test_id: str, angle_deg: float, amplitude: float, rate_per_s: float, cycles: int,
           samples: int) -> TestPlan:
    """Triangle cycles 0 -> ``amplitude`` -> 0 at constant ``rate_per_s``, evenly sampled."""
    half = abs(amplitude) / rate_per_s
    knots = tuple(half * k for k in range(2 * cycles + 1))
    strains = tuple(amplitude * (k % 2) for k in range(2 * cycles + 1))
    return TestPlan(test_id, "cyclic", angle_deg, knots, strains,
                    np.linspace(0.0, knots[-1], samples),
                    f"{cycles} cycles 0 to {amplitude:+.2f} and back at {rate_per_s * 100:g} %/s")


def qlv_stress_pa(time_s: np.ndarray, elastic_pa: np.ndarray, g_inf: float,
                  terms: Sequence[tuple[float, float]]) -> np.ndarray:
    """Quasi-linear viscoelastic stress along a history that starts at rest, Pa.

    ``P(t) = g_inf Pe(t) + sum_k g_k int exp(-(t - s) / tau_k) dPe(s)``, exact for an elastic
    stress ``elastic_pa`` linear in time between samples.

    Args:
        time_s: (n,) sample times, s, non-decreasing (a repeated time is a step).
        elastic_pa: (n,) instantaneous elastic stress Pe at the samples, Pa.
        g_inf: the relaxed fraction of the reduced relaxation function G.
        terms: ``(g_k, tau_k)`` per exponential of G (tau in s).

    Example:
        >>> t = np.array([0.0, 1.0, 101.0])
        >>> qlv_stress_pa(t, np.array([0.0, 1.0, 1.0]), 0.5, [(0.5, 1.0)]).round(3).tolist()
        [0.0, 0.816, 0.5]
    """
    stress = g_inf * elastic_pa
    d_elastic = np.diff(elastic_pa)
    dt = np.diff(time_s)
    for g, tau in terms:
        decay = np.exp(-dt / tau)
        # Share of a linear increment that survives the interval it happens in (the average
        # of exp(-(t_i - s) / tau) over the interval; 1 for a step).
        kept = np.where(dt > 0, -np.expm1(-dt / tau) * tau / np.where(dt > 0, dt, 1.0), 1.0)
        state = np.zeros_like(elastic_pa)
        for i in range(len(dt)):
            state[i + 1] = decay[i] * state[i] + g * d_elastic[i] * kept[i]
        stress = stress + state
    return stress


def true_force_n(plan: TestPlan, stress_pa: StressLaw, area_m2: float,
                 substeps: int = 1) -> np.ndarray:
    """The truth's force at the plan's sample times, N.

    With ``substeps`` > 1 the truth runs on a grid that many times finer than the samples
    (the displacement linear between them, as a reader of ``tests.csv`` reconstructs it) and
    is read back at the samples: a history-dependent truth then sees the path, not its samples.
    """
    if substeps == 1:
        return area_m2 * stress_pa(plan.time_s, plan.strain(), plan.angle_deg)
    fine = np.unique(np.linspace(plan.time_s[:-1], plan.time_s[1:], substeps + 1))
    strain = np.interp(fine, plan.time_s, plan.strain())
    return np.interp(plan.time_s, fine, stress_pa(fine, strain, plan.angle_deg)) * area_m2


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
              digits: Digits) -> str:
    """The ``tests.csv`` text: a header, then one fixed-point row per sample."""
    rows = [_HEADER]
    for plan, (displacement, force) in zip(plans, measured, strict=True):
        rows += [f"{plan.test_id},{plan.mode},{plan.angle_deg:g},{t:.{digits.time_s}f},"
                 f"{d:.{digits.displacement_m}f},{f:.{digits.force_n}f}"
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
        effect: the cause switched on (a name of :data:`EFFECTS`), None for the baseline alone.
        seed: the seed everything was drawn from.
        magnitudes: the drawn parameters: ``young_pa`` (baseline E) always, plus the effect's
            own (see :func:`truth_stress_pa`).
        noise_n: standard deviation of the force noise, N.
    """

    effect: str | None
    seed: int
    magnitudes: dict[str, float]
    noise_n: float


def _log_uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(np.exp(rng.uniform(np.log(low), np.log(high))))


def _ratio(rng: np.random.Generator, low: float, high: float) -> float:
    """A ratio in [low, high] or its inverse, either at even odds."""
    value = rng.uniform(low, high)
    return float(value if rng.random() < 0.5 else 1.0 / value)


def _draw_magnitudes(rng: np.random.Generator, effect: str | None) -> dict[str, float]:
    """The baseline modulus and the effect's parameters."""
    m = {"young_pa": _log_uniform(rng, 8e3, 40e3)}
    if effect == "strain_stiffening":
        m["stiffening"] = rng.uniform(6.0, 14.0)
    elif effect == "anisotropy":
        m["ratio_l_t"] = _ratio(rng, 2.0, 4.0)
    elif effect == "viscoelasticity":
        m["tau1_s"] = _log_uniform(rng, 0.5, 5.0)
        m["tau2_s"] = _log_uniform(rng, 10.0, 100.0)
        relaxed = rng.uniform(0.35, 0.7)
        split = rng.uniform(0.3, 0.7)
        m["g1"], m["g2"] = relaxed * split, relaxed * (1.0 - split)
        m["g_inf"] = 1.0 - relaxed
    elif effect == "tension_compression_asymmetry":
        low, high = (0.25, 0.5) if rng.random() < 0.5 else (2.0, 4.0)
        m["compression_ratio"] = rng.uniform(low, high)
    elif effect == "plasticity":
        m["yield_strain"] = rng.uniform(0.02, 0.05)
        m["tangent_ratio"] = rng.uniform(0.1, 0.3)
    elif effect == "force_offset":
        m["offset_fraction"] = rng.uniform(0.04, 0.12) * rng.choice([-1.0, 1.0])
    elif effect is not None:
        raise MeasurementError(None, "effect",
                               f"unknown effect {effect!r} (known: {EFFECTS})")
    return {key: float(value) for key, value in m.items()}


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
    for angle in (0.0, 90.0):
        # Ramp in 2 s, then a hold sampled densely at first, sparsely later (uneven).
        hold = 2.0 + np.geomspace(0.05, hold_s, int(rng.integers(150, 250)))
        time = np.round(np.concatenate([np.linspace(0.0, 2.0, 41), hold]), 4)
        tests.append(TestPlan(f"r{angle:02.0f}", "relaxation", angle, (0.0, 2.0),
                              (0.0, hold_strain), time))
    for test_id, angle, peak in (("y00", 0.0, rng.uniform(0.10, 0.13)),
                                 ("y90c", 90.0, rng.uniform(-0.15, -0.10))):
        leg = float(np.round(abs(peak) / rate, 4))
        knots = [leg * k for k in range(7)]
        time = _times(rng, knots, [int(rng.integers(30, 60))] * 6)
        tests.append(TestPlan(test_id, "cyclic", angle, tuple(knots),
                              (0.0, peak) * 3 + (0.0,), time))
    return tests


def _elastic_pa(strain: np.ndarray, angle_deg: float, effect: str | None,
                m: dict[str, float]) -> np.ndarray:
    """The rate-independent elastic law of the truth (no plasticity, no relaxation)."""
    young = m["young_pa"]
    if effect == "anisotropy":
        # Geometric mean of E_L and E_T is E; Hill-type mixing of their square roots.
        long, trans = young * np.sqrt(m["ratio_l_t"]), young / np.sqrt(m["ratio_l_t"])
        c2 = np.cos(np.radians(angle_deg)) ** 2
        young = 1.0 / (c2 / np.sqrt(long) + (1.0 - c2) / np.sqrt(trans)) ** 2
    if effect == "strain_stiffening":
        b = m["stiffening"]
        return np.sign(strain) * young / b * np.expm1(b * np.abs(strain))
    if effect == "tension_compression_asymmetry":
        return np.where(strain < 0.0, m["compression_ratio"] * young, young) * strain
    return young * strain


def _plastic(strain: np.ndarray, m: dict[str, float]) -> np.ndarray:
    """1D elastoplasticity, linear kinematic hardening, return mapping at every sample."""
    young = m["young_pa"]
    tangent = m["tangent_ratio"] * young
    hardening = young * tangent / (young - tangent)
    yield_stress = young * m["yield_strain"]
    plastic = back = 0.0
    stress = np.empty_like(strain)
    for i, e in enumerate(strain):
        trial = young * (e - plastic)
        excess = abs(trial - back) - yield_stress
        if excess > 0.0:
            step = excess / (young + hardening) * np.sign(trial - back)
            plastic += step
            back += hardening * step
        stress[i] = young * (e - plastic)
    return stress


def truth_stress_pa(time_s: np.ndarray, strain: np.ndarray, angle_deg: float,
                    effect: str | None, magnitudes: dict[str, float]) -> np.ndarray:
    """Nominal stress of the hidden-effect truth, Pa, at the samples of one test (true strain).

    Baseline ``P = E e`` (``young_pa``). With one effect on:

    - ``strain_stiffening``: ``P = sign(e) E / b (exp(b |e|) - 1)``, b = ``stiffening``.
    - ``anisotropy``: ``E(theta) = 1 / (cos^2/sqrt(E_L) + sin^2/sqrt(E_T))^2`` with
      ``E_L / E_T = ratio_l_t`` and ``sqrt(E_L E_T) = E``.
    - ``viscoelasticity``: quasi-linear, ``G = g_inf + g1 exp(-t/tau1_s) + g2 exp(-t/tau2_s)``.
    - ``tension_compression_asymmetry``: modulus ``compression_ratio * E`` for e < 0.
    - ``plasticity``: yield at ``yield_strain``, post-yield tangent ``tangent_ratio * E``,
      linear kinematic hardening.
    - ``force_offset``: none here (the offset is on the force, :func:`write_hidden_effect_set`).

    Example:
        >>> t = np.array([0.0, 1.0, 2.0])
        >>> truth_stress_pa(t, 0.01 * t, 0.0, None, {"young_pa": 1e4}).tolist()
        [0.0, 100.0, 200.0]
    """
    if effect == "plasticity":
        return _plastic(strain, magnitudes)
    elastic = _elastic_pa(strain, angle_deg, effect, magnitudes)
    if effect == "viscoelasticity":
        m = magnitudes
        return qlv_stress_pa(time_s, elastic, m["g_inf"],
                             ((m["g1"], m["tau1_s"]), (m["g2"], m["tau2_s"])))
    return elastic


_HIDDEN_DIGITS = Digits(time_s=4, displacement_m=10, force_n=8, size_m=5)


def write_hidden_effect_set(folder: Path, seed: int,
                            effect: str | Literal["random"] | None = "random") -> HiddenEffect:
    """Draw a set from ``seed`` with ``effect`` hidden in it, write it in ``folder``, return it.

    Everything comes from ``np.random.default_rng(seed)``, the effect too when it is
    ``"random"``; the draws other than the effect's own parameters do not depend on the
    effect. Writes ``specimen.toml`` and ``tests.csv`` (creating ``folder``).

    Raises:
        MeasurementError: an unknown ``effect``.
    """
    rng = np.random.default_rng(seed)
    index = int(rng.integers(len(EFFECTS)))
    if effect == "random":
        effect = EFFECTS[index]
    elif effect not in EFFECTS:
        raise MeasurementError(None, "effect", f"unknown effect {effect!r} (known: {EFFECTS})")
    edge = rng.uniform(0.008, 0.012)
    size = np.round(edge * (1.0 + ASPECT_SPREAD * rng.uniform(-1.0, 1.0, 3)), 5)
    area, height = float(size[0] * size[1]), float(size[2])
    tests = _protocol(rng)
    magnitudes = _draw_magnitudes(rng, effect)

    def stress(time_s: np.ndarray, strain: np.ndarray, angle_deg: float) -> np.ndarray:
        return truth_stress_pa(time_s, strain, angle_deg, effect, magnitudes)

    forces = [true_force_n(test, stress, area) for test in tests]
    peak = max(float(np.abs(f).max()) for f in forces)
    offset = magnitudes.get("offset_fraction", 0.0) * peak
    noise_n = rng.uniform(0.003, 0.015) * peak
    measured = measure(tests, forces, height, Noise(noise_n, DISPLACEMENT_NOISE_M, offset), rng)
    write_set(folder,
              specimen_toml(_HIDDEN_HEADER, f"hidden-effect-{seed} (synthetic)", size,
                            {"machine": "uniaxial tester (synthetic)"}, _HIDDEN_DIGITS),
              csv_text(tests, measured, _HIDDEN_DIGITS))
    return HiddenEffect(effect, seed, magnitudes, float(noise_n))


def describe(truth: HiddenEffect) -> dict[str, Any]:
    """The truth as plain JSON-able values (for reports)."""
    return {"effect": truth.effect, "seed": truth.seed,
            "magnitudes": {k: float(v) for k, v in truth.magnitudes.items()},
            "noise_n": truth.noise_n}
