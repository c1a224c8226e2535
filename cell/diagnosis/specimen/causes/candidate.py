"""The candidate material of a specimen diagnosis: the baseline springs plus causes of the
catalogue (:mod:`cell.diagnosis.specimen.causes`, one module per cause), each a change to the
mass-spring material with the parameters a fit varies.

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
``orthotropy``                     the sheets' modulus over their normal's, E_s / E_n, their
                                   geometric mean Et (shear and biaxial sets only)
                                   (log E_s / E_n)
``fibre_direction``                the fibres (and sheets) turned about the sheets' normal from
                                   the axes the tests declare (shear and biaxial sets only)
                                   (the turn, degrees)
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
from functools import cached_property
from typing import Any, Literal

import numpy as np

from cell.diagnosis.specimen.causes.base import Parameter
from cell.diagnosis.specimen.causes.registry import REGISTRY, catalogue
from cell.errors import DiagnosisError
from cell.tissue.curves import ModulusCurve
from cell.tissue.material import MassSpringMaterial
from cell.tissue.packedlaw import LATTICE_STIFFENING

UNEXPLAINED = "unexplained"
#: Each test another specimen, the specimens' material spread: a random effect on the fitted
#: material, judged after the search between tests under equal conditions
#: (:mod:`cell.diagnosis.specimen.spread`), not a change to the material a search step adds.
SPECIMEN_VARIABILITY = "specimen_variability"
#: Causes that one model never holds together: the second is the first made non-linear.
EXCLUSIVE = ("viscoelasticity", "nonlinear_viscoelasticity")
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
        causes = catalogue()
        unknown = set(self.causes) - set(causes)
        if unknown:
            raise DiagnosisError(None, "causes",
                                 f"unknown causes {sorted(unknown)}; the catalogue is {causes}")
        if set(EXCLUSIVE) <= set(self.causes):
            raise DiagnosisError(None, "causes", f"{EXCLUSIVE[0]} and {EXCLUSIVE[1]} exclude "
                                 "each other")
        object.__setattr__(self, "causes", tuple(c for c in causes if c in self.causes))

    @property
    def relaxes(self) -> bool:
        """Whether the model has a relaxation function (either kind of viscoelasticity)."""
        return any(c in self.causes for c in EXCLUSIVE)

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

    # Cached: a fit reads them at every step, and the model never changes.
    @cached_property
    def parameters(self) -> tuple[Parameter, ...]:
        """The shape parameters, each cause's in catalogue order, as its cause declares
        them."""
        return tuple(p for c in self.causes for p in REGISTRY[c].parameters(self))

    @cached_property
    def parameter_names(self) -> tuple[str, ...]:
        """Names of the shape parameters, in vector order."""
        return tuple(p.name for p in self.parameters)

    @property
    def initial(self) -> np.ndarray:
        """A starting point for the shape parameters."""
        return np.array([p.initial for p in self.parameters])

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the shape parameters."""
        parameters = self.parameters
        return np.array([p.low for p in parameters]), np.array([p.high for p in parameters])

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
        fields: dict[str, Any] = {}
        for cause in self.causes:
            fields.update(REGISTRY[cause].fields(value, self))
        return MassSpringMaterial(
            longitudinal=curve(el),
            transverse=curve(et),
            longitudinal_compression=el_c if asymmetric else None,
            transverse_compression=et_c if asymmetric else None,
            density_kg_m3=density_kg_m3,
            geometric_compensation=LATTICE_STIFFENING,
            **fields,
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
        if "orthotropy" in self.causes:
            params["sheet_over_normal"] = material.sheet_over_normal
        if "fibre_direction" in self.causes:
            params["fibre_turn_deg"] = value["fibre_turn_deg"]
        if self.has_offset:
            params["force_offset_n"] = offset_n
        return params


def cause_of(name: str, model: CandidateMaterial) -> str:
    """The cause of ``model`` that declares the shape parameter ``name``.

    Raises:
        DiagnosisError: no cause of ``model`` declares ``name``.

    Example:
        >>> cause_of("log_relaxation_time_1", CandidateMaterial(("viscoelasticity",)))
        'viscoelasticity'
    """
    for cause in model.causes:
        if any(p.name == name for p in REGISTRY[cause].parameters(model)):
            return cause
    raise DiagnosisError(None, "parameter", f"no cause of {model.name} declares {name!r}")
