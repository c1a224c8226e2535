"""The truth laws of the hidden-effect sets: the drawn magnitudes of each effect and the
nominal stress they give, any number of effects at once.

Part of the answer key with :mod:`cell.synthetic.specimen`: the diagnosis never imports it.
Nominal stress ``P`` (Pa) against nominal strain ``e``, built in layers:

1. plastic strain p (strain-space return mapping, linear kinematic hardening, as the springs);
2. the elastic law of ``e - p``: ``E(theta) e`` with anisotropy's ``E(theta)``, the asymmetry's
   factor in compression, stiffening's ``sign(e) E / b (exp(b |e|) - 1)``;
3. relaxation of that stress ``Pe``: the relaxing part ``R = F(e) Pe`` (``F`` the fraction that
   relaxes, constant for quasi-linear viscoelasticity, linear in ``|e|`` for the non-linear
   kind), ``P = Pe - R + sum_k g_k int exp(-(t - s) / tau_k) dR(s)``, ``sum g_k = 1``;
4. the load cell's offset is added to the force by the writer, not here.

Example:
    >>> m = draw_magnitudes(np.random.default_rng(0), ("anisotropy",), 1.0)
    >>> sorted(m)
    ['ratio_l_t', 'young_pa']
    >>> t = np.array([0.0, 1.0, 2.0])
    >>> truth_stress_pa(t, 0.01 * t, 0.0, {"young_pa": 1e4}).tolist()
    [0.0, 100.0, 200.0]
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from cell.diagnosis.specimen.causes import EXCLUSIVE, UNIAXIAL_CAUSES
from cell.errors import MeasurementError

#: Strain at which a non-linear relaxation's drawn fraction ``relaxed`` holds.
REFERENCE_STRAIN = 0.1
#: The relaxed fraction stays within these bounds whatever the strain.
_FRACTION_BOUNDS = (0.05, 0.95)


def _log_uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(np.exp(rng.uniform(np.log(low), np.log(high))))


def _ratio(rng: np.random.Generator, low: float, high: float) -> float:
    """A ratio in [low, high] or its inverse, either at even odds."""
    value = rng.uniform(low, high)
    return float(value if rng.random() < 0.5 else 1.0 / value)


def check_effects(effects: Sequence[str]) -> tuple[str, ...]:
    """``effects`` in catalogue order, checked: known, no repeat, not both viscoelasticities.

    Raises:
        MeasurementError: naming the effect at fault.
    """
    unknown = [e for e in effects if e not in UNIAXIAL_CAUSES]
    if unknown or len(set(effects)) != len(effects) or set(EXCLUSIVE) <= set(effects):
        raise MeasurementError(None, "effect", f"bad effects {tuple(effects)!r}: each once, "
                               f"from {UNIAXIAL_CAUSES}, not both of {EXCLUSIVE}")
    return tuple(c for c in UNIAXIAL_CAUSES if c in effects)


def draw_magnitudes(rng: np.random.Generator, effects: Sequence[str],
                    strength: float) -> dict[str, float]:
    """The baseline modulus and each effect's parameters, drawn in catalogue order.

    ``strength`` in (0, 1] moves every effect towards none (1: the full draws, 0.5: half as
    strong: half the exponent, the log ratios and the relaxed fractions).
    """
    m = {"young_pa": _log_uniform(rng, 8e3, 40e3)}
    for effect in check_effects(effects):
        if effect == "strain_stiffening":
            m["stiffening"] = strength * rng.uniform(6.0, 14.0)
        elif effect == "anisotropy":
            m["ratio_l_t"] = _ratio(rng, 2.0, 4.0) ** strength
        elif effect in EXCLUSIVE:
            m["tau1_s"] = _log_uniform(rng, 0.5, 5.0)
            m["tau2_s"] = _log_uniform(rng, 10.0, 100.0)
            m["relaxed"] = strength * rng.uniform(0.35, 0.7)
            m["split"] = rng.uniform(0.3, 0.7)
            if effect == "nonlinear_viscoelasticity":
                m["relaxed_per_strain"] = (strength * rng.uniform(2.5, 4.0)
                                           * rng.choice([-1.0, 1.0]))
        elif effect == "tension_compression_asymmetry":
            low, high = (0.25, 0.5) if rng.random() < 0.5 else (2.0, 4.0)
            m["compression_ratio"] = rng.uniform(low, high) ** strength
        elif effect == "plasticity":
            m["yield_strain"] = rng.uniform(0.02, 0.05)
            m["tangent_ratio"] = 1.0 - strength * (1.0 - rng.uniform(0.1, 0.3))
        elif effect == "force_offset":
            m["offset_fraction"] = strength * rng.uniform(0.04, 0.12) * rng.choice([-1.0, 1.0])
    return {key: float(value) for key, value in m.items()}


def plastic_strain(strain: np.ndarray, m: dict[str, float]) -> np.ndarray:
    """Plastic strain along ``strain``: yield at ``yield_strain`` around the back strain
    ``H p`` (H from the post-yield tangent ratio h, ``h / (1 - h)``), zero without plasticity."""
    if "yield_strain" not in m:
        return np.zeros_like(strain)
    back = m["tangent_ratio"] / (1.0 - m["tangent_ratio"])
    plastic = 0.0
    out = np.empty_like(strain)
    for i, e in enumerate(strain):
        over = e - plastic * (1.0 + back)
        if abs(over) > m["yield_strain"]:
            plastic += (over - np.sign(over) * m["yield_strain"]) / (1.0 + back)
        out[i] = plastic
    return out


def elastic_stress_pa(strain: np.ndarray, angle_deg: float, m: dict[str, float]) -> np.ndarray:
    """The rate-independent elastic law of the truth at elastic strain ``strain``, Pa."""
    young = m["young_pa"]
    if "ratio_l_t" in m:
        # Geometric mean of E_L and E_T is E; Hill-type mixing of their square roots.
        long, trans = young * np.sqrt(m["ratio_l_t"]), young / np.sqrt(m["ratio_l_t"])
        c2 = np.cos(np.radians(angle_deg)) ** 2
        young = 1.0 / (c2 / np.sqrt(long) + (1.0 - c2) / np.sqrt(trans)) ** 2
    modulus = np.where(strain < 0.0, m.get("compression_ratio", 1.0) * young, young)
    if "stiffening" in m:
        b = m["stiffening"]
        return np.sign(strain) * modulus / b * np.expm1(b * np.abs(strain))
    return modulus * strain


def relaxed_fraction(strain: np.ndarray, m: dict[str, float]) -> np.ndarray:
    """The fraction of the elastic stress that relaxes under a hold at ``strain``."""
    slope = m.get("relaxed_per_strain", 0.0)
    return np.clip(m["relaxed"] + slope * (np.abs(strain) - REFERENCE_STRAIN),
                   *_FRACTION_BOUNDS)


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


def relaxing_stress_pa(time_s: np.ndarray, elastic_pa: np.ndarray, fraction: np.ndarray,
                       terms: Sequence[tuple[float, float]]) -> np.ndarray:
    """``Pe - R + sum_k g_k int exp(-(t - s) / tau_k) dR(s)`` with ``R = fraction Pe``, Pa
    (module docstring, layer 3; ``terms`` are ``(g_k, tau_k)`` with ``sum g_k = 1``)."""
    relaxing = fraction * elastic_pa
    return elastic_pa - relaxing + qlv_stress_pa(time_s, relaxing, 0.0, terms)


def truth_stress_pa(time_s: np.ndarray, strain: np.ndarray, angle_deg: float,
                    magnitudes: dict[str, float]) -> np.ndarray:
    """Nominal stress of the truth, Pa, at the samples of one test (module docstring): the
    effects on are those whose parameters ``magnitudes`` holds (:func:`draw_magnitudes`)."""
    m = magnitudes
    elastic = elastic_stress_pa(strain - plastic_strain(strain, m), angle_deg, m)
    if "relaxed" not in m:
        return elastic
    terms = ((m["split"], m["tau1_s"]), (1.0 - m["split"], m["tau2_s"]))
    return relaxing_stress_pa(time_s, elastic, relaxed_fraction(strain, m), terms)
