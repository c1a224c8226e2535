"""The catalogue of causes: each one a change to the mass-spring material, with the parameters
a fit varies.

A :class:`CandidateMaterial` is the baseline (linear, isotropic, rate-independent springs of
modulus E, their lattice's geometric stiffening compensated so that "linear" means a linear
nominal stress-strain curve, as measured data reads) plus some causes of the catalogue; it
maps a vector of *shape* parameters, E and a load-cell offset to a
:class:`~cell.tissue.material.MassSpringMaterial` that the muscles can run.
The simulated force is linear in E (every part of the spring law scales with it) and in the
offset, so a fit solves for those two in closed form and searches only the shape parameters.

=================================  ==============================================================
cause                              change to the material (shape parameters)
=================================  ==============================================================
``strain_stiffening``              both moduli follow the exponential law E exp(b ``|r - 1|``)
                                   or the paper's polynomial E (1 + k (r - 1)**2), b or k apart
                                   in tension and compression
``anisotropy``                     El = E exp(q / 2) along the fibres, Et = E exp(-q / 2), the
                                   oblique springs' factor, and both apart in compression
                                   (tissue's anisotropy differs there, and so does the
                                   lattice's) (q, oblique, q_c, oblique_c)
``viscoelasticity``                quasi-linear relaxation: the fraction that relaxes, its
                                   shares among the terms (stick-breaking), each term's time
                                   (log10 s) within the tests' span
``nonlinear_viscoelasticity``      the same, its relaxed fraction (held at the set's reference
                                   strain) growing or shrinking linearly with the strain held
                                   (its slope per unit strain); it replaces
                                   ``viscoelasticity``, never joins it
``tension_compression_asymmetry``  El and Et of compressed springs (their logs over the
                                   tension ones)
``plasticity``                     yield strain and hardening ratio of every spring
``force_offset``                   the load cell reads a constant offset (a rig effect: it is
                                   not part of the material the muscles get)
=================================  ==============================================================

Example:
    >>> model = CandidateMaterial(("anisotropy",))
    >>> model.parameter_names
    ('log_el_over_et', 'log_el_over_et_compressed')
    >>> model.material(model.initial, 1e4, 1060.0).longitudinal.small_strain_modulus_pa
    10000.0
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from cell.errors import DiagnosisError
from cell.tissue.curves import ModulusCurve
from cell.tissue.material import MassSpringMaterial
from cell.tissue.packedlaw import LATTICE_STIFFENING

CAUSES = (
    "strain_stiffening",
    "anisotropy",
    "viscoelasticity",
    "nonlinear_viscoelasticity",
    "tension_compression_asymmetry",
    "plasticity",
    "force_offset",
)
UNEXPLAINED = "unexplained"
#: Each test another specimen, the specimens' material spread: a random effect on the fitted
#: material, judged after the search between tests under equal conditions
#: (:mod:`cell.diagnosis.specimen.spread`), not a change to the material a search step adds.
SPECIMEN_VARIABILITY = "specimen_variability"
#: Causes that one model never holds together: the second is the first made non-linear.
EXCLUSIVE = ("viscoelasticity", "nonlinear_viscoelasticity")
RELAXING = EXCLUSIVE
Stiffening = Literal["exponential", "polynomial"]


@dataclass(frozen=True)
class CandidateMaterial:
    """The baseline springs plus ``causes`` (module docstring).

    Attributes:
        causes: causes of the catalogue, in any order.
        stiffening: the strain-stiffening law, when ``strain_stiffening`` is a cause.
        time_range_s: (shortest, longest) relaxation time a fit may give, s; the terms start
            spread evenly in log time over it.
        relaxation_terms: exponential terms of the relaxation function.
        stretch_range: (r_min, r_max) over which a stiffening curve holds; outside it the
            modulus stays at its value at the bound.
        oblique: whether ``anisotropy`` also fits the oblique springs' factor.
        compression_per_direction: whether ``tension_compression_asymmetry`` scales El and Et
            of compressed springs apart (else by one factor).
        reference_strain: the spring strain at which ``relaxed_fraction`` holds for
            ``nonlinear_viscoelasticity`` (the fraction is linear in the strain around it: a
            fraction that grows from none at small strains is one no positive fraction at zero
            strain can give).

    Raises:
        DiagnosisError: an unknown cause, or both kinds of viscoelasticity.

    Example:
        >>> CandidateMaterial(("plasticity",)).parameter_names
        ('yield_strain', 'hardening')
    """

    causes: tuple[str, ...] = ()
    stiffening: Stiffening = "exponential"
    time_range_s: tuple[float, float] = (0.1, 300.0)
    relaxation_terms: int = 2
    stretch_range: tuple[float, float] = (0.5, 1.5)
    oblique: bool = False
    compression_per_direction: bool = False
    reference_strain: float = 0.1

    def __post_init__(self) -> None:
        unknown = set(self.causes) - set(CAUSES)
        if unknown:
            raise DiagnosisError(None, "causes",
                                 f"unknown causes {sorted(unknown)}; the catalogue is {CAUSES}")
        if set(EXCLUSIVE) <= set(self.causes):
            raise DiagnosisError(None, "causes", f"{EXCLUSIVE[0]} and {EXCLUSIVE[1]} exclude "
                                 "each other")
        object.__setattr__(self, "causes", tuple(c for c in CAUSES if c in self.causes))

    @property
    def relaxes(self) -> bool:
        """Whether the model has a relaxation function (either kind of viscoelasticity)."""
        return any(c in self.causes for c in RELAXING)

    @property
    def name(self) -> str:
        """A short description, e.g. ``mass_spring linear isotropic + anisotropy``."""
        if not self.causes:
            return "mass_spring linear isotropic rate-independent"
        variant = {"strain_stiffening": f" ({self.stiffening})",
                   "anisotropy": " (Eq. 10 with oblique factor)" if self.oblique else " (Eq. 10)",
                   "tension_compression_asymmetry": " (El and Et apart)"
                   if self.compression_per_direction else " (one factor)"}
        parts = [c + variant.get(c, "") for c in self.causes]
        return "mass_spring + " + " + ".join(parts)

    @property
    def has_offset(self) -> bool:
        """Whether the load cell's offset is fitted."""
        return "force_offset" in self.causes

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Names of the shape parameters, in vector order."""
        names: list[str] = []
        if "strain_stiffening" in self.causes:
            names.append("stiffening_exponent" if self.stiffening == "exponential"
                         else "stiffening_quadratic")
            # Its own in compression: the lattice stiffens apart there, and one exponent
            # would name an asymmetry in every stiffening set.
            names.append(f"compression_{names[0]}")
        if "anisotropy" in self.causes:
            names += ["log_el_over_et", "oblique"] if self.oblique else ["log_el_over_et"]
            names.append("log_el_over_et_compressed")
            if self.oblique:
                names.append("oblique_compressed")
        if self.relaxes:
            names.append("relaxed_fraction")
            names += [f"relaxation_share_{k}" for k in range(self.relaxation_terms - 1)]
            names += [f"log_relaxation_time_{k}" for k in range(self.relaxation_terms)]
        if "nonlinear_viscoelasticity" in self.causes:
            names.append("relaxed_fraction_slope")
        if "tension_compression_asymmetry" in self.causes:
            names += (["log_el_compression", "log_et_compression"]
                      if self.compression_per_direction else ["log_compression"])
        if "plasticity" in self.causes:
            names += ["yield_strain", "hardening"]
        return tuple(names)

    @property
    def initial(self) -> np.ndarray:
        """A starting point for the shape parameters."""
        start = {"stiffening_exponent": 4.0, "stiffening_quadratic": 10.0,
                 "yield_strain": 0.03, "hardening": 0.3, "oblique": 0.0,
                 "oblique_compressed": 0.0,
                 "relaxed_fraction_slope": 0.0, "relaxed_fraction": 0.3}
        low, high = np.log10(self.time_range_s)
        times = np.linspace(low, high, self.relaxation_terms + 2)[1:-1]
        start.update({f"log_relaxation_time_{k}": float(t) for k, t in enumerate(times)})
        start.update({f"relaxation_share_{k}": 1.0 / (self.relaxation_terms - k)
                      for k in range(self.relaxation_terms - 1)})
        return np.array([start.get(n.removeprefix("compression_"),
                                   0.0 if n.startswith("log_") else 0.3)
                         for n in self.parameter_names])

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the shape parameters."""
        limits = {"stiffening_exponent": (0.0, 40.0), "stiffening_quadratic": (0.0, 400.0),
                  "log_el_over_et": (-1.6, 1.6), "oblique": (-0.8, 3.0),
                  "oblique_compressed": (-0.8, 3.0),
                  "log_el_over_et_compressed": (-1.6, 1.6),
                  "log_el_compression": (-3.0, 3.0), "log_compression": (-3.0, 3.0),
                  "log_et_compression": (-3.0, 3.0), "yield_strain": (0.002, 0.4),
                  "hardening": (0.0, 0.95), "relaxed_fraction_slope": (-10.0, 10.0),
                  "relaxed_fraction": (0.0, 0.98)}
        low, high = np.log10(self.time_range_s)
        limits.update({f"log_relaxation_time_{k}": (float(low), float(high))
                       for k in range(self.relaxation_terms)})
        limits.update({f"relaxation_share_{k}": (0.0, 1.0)
                       for k in range(self.relaxation_terms - 1)})
        pairs = [limits.get(n.removeprefix("compression_"), (0.0, 30.0))
                 for n in self.parameter_names]
        return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])

    def values(self, shape: np.ndarray) -> dict[str, float]:
        """The shape parameters by name."""
        return dict(zip(self.parameter_names, (float(v) for v in shape), strict=True))

    def material(self, shape: np.ndarray, modulus_pa: float,
                 density_kg_m3: float) -> MassSpringMaterial:
        """The material for ``shape`` and small-strain modulus ``modulus_pa`` (the geometric
        mean of El and Et), fibres along x (the muscles' length)."""
        value = self.values(shape)
        ratio = math.exp(value.get("log_el_over_et", 0.0))
        r_min, r_max = self.stretch_range

        def curve(modulus: float, prefix: str = "") -> ModulusCurve:
            if "stiffening_exponent" in value:
                return ModulusCurve.exponential(
                    modulus, value[f"{prefix}stiffening_exponent"], r_min, r_max)
            quadratic = value.get(f"{prefix}stiffening_quadratic", 0.0)
            return ModulusCurve((modulus, 0.0, modulus * quadratic, 0.0, 0.0, 0.0), r_min, r_max)

        el, et = modulus_pa * math.sqrt(ratio), modulus_pa / math.sqrt(ratio)
        asymmetric = ("tension_compression_asymmetry" in self.causes
                      or "log_el_over_et_compressed" in value
                      or any(n.startswith("compression_") for n in value))
        if asymmetric:
            squeezed = "compression_" if any(n.startswith("compression_") for n in value) else ""
            common = value.get("log_compression", 0.0)
            ratio_c = math.exp(value.get("log_el_over_et_compressed", math.log(ratio)))
            el_c = curve(modulus_pa * math.sqrt(ratio_c)
                         * math.exp(value.get("log_el_compression", common)), squeezed)
            et_c = curve(modulus_pa / math.sqrt(ratio_c)
                         * math.exp(value.get("log_et_compression", common)), squeezed)
        weights = _relaxation_weights(value, self.relaxation_terms) if self.relaxes else ()
        times = tuple(10.0 ** value[n] for n in self.parameter_names
                      if n.startswith("log_relaxation_time_"))
        return MassSpringMaterial(
            longitudinal=curve(el),
            transverse=curve(et),
            longitudinal_compression=el_c if asymmetric else None,
            transverse_compression=et_c if asymmetric else None,
            density_kg_m3=density_kg_m3,
            relaxation_weights=tuple(weights),
            relaxation_times_s=times,
            relaxation_strain_slope=_strain_slope(value),
            relaxation_reference_strain=self.reference_strain if "relaxed_fraction_slope"
            in value else 0.0,
            yield_strain=value.get("yield_strain", 0.0),
            hardening=value.get("hardening", 0.0),
            geometric_compensation=LATTICE_STIFFENING,
            oblique=value.get("oblique", 0.0),
            oblique_compression=value.get("oblique_compressed"),
        )

    def reported(self, shape: np.ndarray, modulus_pa: float,
                 offset_n: float) -> dict[str, float]:
        """The fitted parameters in physical units, for people and the JSON report."""
        material = self.material(shape, modulus_pa, 1.0)
        params = {"young_pa": modulus_pa}
        value = self.values(shape)
        params.update({n: v for n, v in value.items() if "stiffening_" in n})
        if "anisotropy" in self.causes:
            params["el_pa"] = material.longitudinal.small_strain_modulus_pa
            params["et_pa"] = material.transverse.small_strain_modulus_pa
            if self.oblique:
                params["oblique"] = material.oblique
                params["oblique_compression"] = material.in_compression().oblique
        if self.relaxes:
            for k, (g, tau) in enumerate(zip(material.relaxation_weights,
                                             material.relaxation_times_s, strict=True)):
                params[f"relaxation_weight_{k}"] = g
                params[f"relaxation_time_{k}_s"] = tau
        if "nonlinear_viscoelasticity" in self.causes:
            params["relaxation_strain_slope"] = material.relaxation_strain_slope
            params["relaxation_reference_strain"] = material.relaxation_reference_strain
        if material.longitudinal_compression is not None:
            params["el_compression_pa"] = material.longitudinal_compression.coefficients[0]
            params["et_compression_pa"] = material.transverse_compression.coefficients[0]
        if "plasticity" in self.causes:
            params["yield_strain"] = material.yield_strain
            params["hardening"] = material.hardening
        if self.has_offset:
            params["force_offset_n"] = offset_n
        return params


def _relaxation_weights(value: dict[str, float], terms: int) -> tuple[float, ...]:
    """g_k from the relaxed fraction and its shares (stick-breaking: term k takes share k of
    what the terms before it left, the last term the rest)."""
    left = value["relaxed_fraction"]
    weights = []
    for k in range(terms - 1):
        weights.append(left * value[f"relaxation_share_{k}"])
        left -= weights[-1]
    return (*weights, left)


def _strain_slope(value: dict[str, float]) -> float:
    """The spring law's c from the fitted slope of the relaxed fraction per unit strain (the
    fraction ``G (1 + c (|x| - x_r))`` has slope ``G c``); 0 when nothing relaxes."""
    fraction = value.get("relaxed_fraction", 0.0)
    if fraction <= 0.0:
        return 0.0
    return value.get("relaxed_fraction_slope", 0.0) / fraction
