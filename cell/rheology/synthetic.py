"""Synthetic measurement sets with one hidden effect: the generator the diagnosis is tested on.

:func:`write_hidden_effect_set` draws, from one seed, a specimen, a linear isotropic baseline,
at most one effect of the diagnosis catalogue with random magnitudes, a test protocol and the
noise; it writes the set in the measured-data format (``specimen.toml``, ``tests.csv``) and
returns the truth. The files hold no truth parameter. The diagnosis (:mod:`cell.rheology.diagnosis`)
never imports this module: it is the answer key (an import-rule test holds it to that).

Truth model: nominal stress ``P`` (Pa) against nominal strain ``e = displacement / height``,
force ``= P * area``. The baseline is ``P = E e``; each effect changes it as the docstring of
:func:`truth_stress_pa` says. The protocol (ten tests, 150 to 400 samples each, some unevenly
sampled) shows every effect: ramps in tension at three angles and in compression at two, a
ramp ten times faster, two relaxation holds, load/unload cycles in tension and in compression.

Example:
    >>> truth = write_hidden_effect_set(Path("out/hidden-7"), seed=7)  # doctest: +SKIP
    >>> truth.effect in EFFECTS  # doctest: +SKIP
    True
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from cell.rheology.causes import CAUSES

EFFECTS: tuple[str | None, ...] = (*CAUSES, None)
"""The effects one set can hide: the six causes of the catalogue, and None (baseline alone)."""

DENSITY_KG_M3 = 1060.0
ASPECT_SPREAD = 0.03
"""Each edge of the (near-cubic) specimen is the drawn edge times 1 +- up to this."""
DISPLACEMENT_NOISE_M = 0.2e-6
_HEADER = "test_id,mode,angle_deg,time_s,displacement_m,force_N"


@dataclass(frozen=True)
class HiddenEffect:
    """The truth behind one synthetic set.

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


@dataclass(frozen=True)
class _Test:
    """One test of the protocol: the true displacement history at its sample times."""

    test_id: str
    mode: str
    angle_deg: float
    time_s: np.ndarray
    strain: np.ndarray


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
        raise ValueError(f"unknown effect {effect!r} (known: {EFFECTS})")
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


def _protocol(rng: np.random.Generator) -> list[_Test]:
    """The ten tests: ramps, a fast ramp, relaxation holds, cycles; the strain at each sample."""
    rate = rng.uniform(0.005, 0.02)  # base strain rate, 1/s
    tension = rng.uniform(0.10, 0.18)
    compression = rng.uniform(-0.25, -0.15)
    mid = float(np.round(rng.uniform(30.0, 60.0)))
    tests: list[_Test] = []

    def ramp(test_id: str, mode: str, angle: float, peak: float, speed: float,
             uneven: bool = False) -> None:
        end = float(np.round(abs(peak) / speed, 4))
        time = _times(rng, [0.0, end], [int(rng.integers(150, 300))], uneven)
        tests.append(_Test(test_id, mode, angle, time, np.interp(time, [0, end], [0, peak])))

    ramp("t00", "tension", 0.0, tension, rate)
    ramp(f"t{mid:02.0f}", "tension", mid, tension, rate, uneven=True)
    ramp("t90", "tension", 90.0, tension, rate)
    ramp("c00", "compression", 0.0, compression, rate)
    ramp("c90", "compression", 90.0, compression, rate, uneven=True)
    ramp("t00-fast", "tension", 0.0, tension, 10.0 * rate)
    hold_strain, hold_s = rng.uniform(0.08, 0.12), float(np.round(rng.uniform(60.0, 120.0)))
    for angle in (0.0, 90.0):
        # Ramp in 2 s, then a hold sampled densely at first, sparsely later (uneven).
        hold = 2.0 + np.geomspace(0.05, hold_s, int(rng.integers(150, 250)))
        time = np.round(np.concatenate([np.linspace(0.0, 2.0, 41), hold]), 4)
        strain = np.interp(time, [0.0, 2.0], [0.0, hold_strain])
        tests.append(_Test(f"r{angle:02.0f}", "relaxation", angle, time, strain))
    for test_id, angle, peak in (("y00", 0.0, rng.uniform(0.10, 0.13)),
                                 ("y90c", 90.0, rng.uniform(-0.15, -0.10))):
        leg = float(np.round(abs(peak) / rate, 4))
        knots = [leg * k for k in range(7)]
        time = _times(rng, knots, [int(rng.integers(30, 60))] * 6)
        strain = np.interp(time, knots, [0.0, peak] * 3 + [0.0])
        tests.append(_Test(test_id, "cyclic", angle, time, strain))
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


def _viscoelastic(time: np.ndarray, elastic: np.ndarray, m: dict[str, float]) -> np.ndarray:
    """Quasi-linear viscoelasticity, exact for an elastic stress linear in time between samples.

    P = g_inf Pe + sum_k h_k with h_k(t) = g_k int exp(-(t - s) / tau_k) dPe(s).
    """
    stress = m["g_inf"] * elastic
    for g, tau in ((m["g1"], m["tau1_s"]), (m["g2"], m["tau2_s"])):
        h = np.zeros_like(elastic)
        for i in range(1, len(time)):
            dt = time[i] - time[i - 1]
            rise = elastic[i] - elastic[i - 1]
            decay = np.exp(-dt / tau)
            # Average of exp(-(t_i - s)/tau) over the interval (1 when dt = 0).
            weight = -np.expm1(-dt / tau) * tau / dt if dt > 0 else 1.0
            h[i] = decay * h[i - 1] + g * rise * weight
        stress = stress + h
    return stress


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
    """Nominal stress of the truth model, Pa, at the samples of one test (true strain).

    Baseline ``P = E e`` (``young_pa``). With one effect on:

    - ``strain_stiffening``: ``P = sign(e) E / b (exp(b |e|) - 1)``, b = ``stiffening``.
    - ``anisotropy``: ``E(theta) = 1 / (cos^2/sqrt(E_L) + sin^2/sqrt(E_T))^2`` with
      ``E_L / E_T = ratio_l_t`` and ``sqrt(E_L E_T) = E``.
    - ``viscoelasticity``: quasi-linear, ``G = g_inf + g1 exp(-t/tau1_s) + g2 exp(-t/tau2_s)``.
    - ``tension_compression_asymmetry``: modulus ``compression_ratio * E`` for e < 0.
    - ``plasticity``: yield at ``yield_strain``, post-yield tangent ``tangent_ratio * E``,
      linear kinematic hardening.
    - ``force_offset``: none here (the offset is on the force, :func:`write_hidden_effect_set`).
    """
    if effect == "plasticity":
        return _plastic(strain, magnitudes)
    elastic = _elastic_pa(strain, angle_deg, effect, magnitudes)
    if effect == "viscoelasticity":
        return _viscoelastic(time_s, elastic, magnitudes)
    return elastic


def _format(value: float, digits: int) -> str:
    text = f"{value:.{digits}f}"
    return "0." + "0" * digits if text == "-0." + "0" * digits else text


def write_hidden_effect_set(folder: Path, seed: int,
                            effect: str | Literal["random"] | None = "random") -> HiddenEffect:
    """Draw a set from ``seed`` with ``effect`` hidden in it, write it in ``folder``, return it.

    Everything comes from ``np.random.default_rng(seed)``, the effect too when it is
    ``"random"``; the draws other than the effect's own parameters do not depend on the
    effect. Writes ``specimen.toml`` and ``tests.csv`` (creating ``folder``).
    """
    rng = np.random.default_rng(seed)
    index = int(rng.integers(len(EFFECTS)))
    if effect == "random":
        effect = EFFECTS[index]
    elif effect not in EFFECTS:
        raise ValueError(f"unknown effect {effect!r} (known: {EFFECTS})")
    edge = rng.uniform(0.008, 0.012)
    size = np.round(edge * (1.0 + ASPECT_SPREAD * rng.uniform(-1.0, 1.0, 3)), 5)
    area, height = float(size[0] * size[1]), float(size[2])
    tests = _protocol(rng)
    magnitudes = _draw_magnitudes(rng, effect)
    forces = [area * truth_stress_pa(t.time_s, t.strain, t.angle_deg, effect, magnitudes)
              for t in tests]
    peak = max(float(np.abs(f).max()) for f in forces)
    offset = magnitudes.get("offset_fraction", 0.0) * peak
    noise_n = rng.uniform(0.003, 0.015) * peak
    rows = [_HEADER]
    for test, force in zip(tests, forces, strict=True):
        measured = force + offset + rng.normal(0.0, noise_n, force.shape)
        displacement = test.strain * height + rng.normal(0.0, DISPLACEMENT_NOISE_M,
                                                         force.shape)
        displacement[0] = 0.0
        rows += [f"{test.test_id},{test.mode},{test.angle_deg:g},{t:.4f},"
                 f"{_format(d, 10)},{_format(f, 8)}"
                 for t, d, f in zip(test.time_s, displacement, measured, strict=True)]
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "specimen.toml").write_text(
        "# SYNTHETIC measurement set: no tissue was tested. Drawn from a seeded truth model with\n"
        "# noise by the project's hidden-effect generator, to test the diagnosis against it;\n"
        "# the truth is kept out of these files.\n\n"
        "[specimen]\n"
        f'name = "hidden-effect-{seed} (synthetic)"\n'
        f"size_m = [{size[0]:.5f}, {size[1]:.5f}, {size[2]:.5f}]\n"
        f"density_kg_m3 = {DENSITY_KG_M3:.1f}\n"
        "# The load axis is specimen z; the fibres lie in the x-z plane at each test's "
        "angle_deg.\n\n"
        "[rig]\n"
        'machine = "uniaxial tester (synthetic)"\n')
    (folder / "tests.csv").write_text("\n".join(rows) + "\n")
    return HiddenEffect(effect, seed, magnitudes, float(noise_n))


def describe(truth: HiddenEffect) -> dict[str, Any]:
    """The truth as plain JSON-able values (for reports)."""
    return {"effect": truth.effect, "seed": truth.seed,
            "magnitudes": {k: float(v) for k, v in truth.magnitudes.items()},
            "noise_n": truth.noise_n}
