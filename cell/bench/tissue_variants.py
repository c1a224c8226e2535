"""The tissue models the tissue bench compares, the paper's Fig. 10 material, and the
scenario each runs in."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from cell.sim.assembly import build_scene
from cell.sim.scenario import Scenario, SimulationParams
from cell.sim.simulation import TissueSimulation
from cell.tissue.geometry import MuscleShape
from cell.tissue.material import ContinuumMaterial, MassSpringMaterial, default_meat

#: The paper's dashpot per spring (Fig. 8), N s/m.
PAPER_SPRING_DAMPING_N_S_M = 0.1


@dataclass(frozen=True)
class TissueVariant:
    """One tissue model of the bench.

    Attributes:
        key: identifier in the JSON report.
        label: what it is, for the tables.
        material: its material (the family follows from the type).
        tissue_step: how the springs are integrated (:class:`SimulationParams`).

    Example:
        >>> TissueVariant("linear", "StVK continuum", ContinuumMaterial()).family
        'continuum'
    """

    key: str
    label: str
    material: ContinuumMaterial | MassSpringMaterial
    tissue_step: Literal["implicit", "explicit"] = "explicit"

    @property
    def family(self) -> Literal["continuum", "mass_spring"]:
        """``"continuum"`` (MuJoCo's flex elasticity) or ``"mass_spring"`` (ours)."""
        return "continuum" if isinstance(self.material, ContinuumMaterial) else "mass_spring"


def tissue_variants() -> tuple[TissueVariant, ...]:
    """The seven models the bench compares: the default meat with the implicit step (at the
    scenario's step, :mod:`cell.tissue.implicit`) and, as peers, every model with MuJoCo's
    explicit step of the springs.

    The continuum models keep the paper's E = 0.03 MPa (ContinuumMaterial's default); the
    plastic one yields at 5% strain, so that the 10% tension test flows. The linear mass-spring
    models take the small-strain moduli of :func:`default_meat` (isotropic: the paper's
    0.03 MPa), so that anisotropy and non-linearity are the only differences between them.

    Example:
        >>> [m.key for m in tissue_variants()][:2]
        ['continuum_linear', 'continuum_nonlinear']
    """
    meat = default_meat()
    el = meat.longitudinal.small_strain_modulus_pa
    et = meat.transverse.small_strain_modulus_pa
    return (
        TissueVariant("continuum_linear", "continuum StVK", ContinuumMaterial(law="stvk")),
        TissueVariant("continuum_nonlinear", "continuum neo-Hookean",
                    ContinuumMaterial(law="neo_hookean")),
        TissueVariant("continuum_plastic", "continuum StVK + von Mises (yield 5%)",
                    ContinuumMaterial(law="stvk", yield_strain=0.05)),
        TissueVariant("mass_spring_isotropic", "mass-spring isotropic 30 kPa",
                    MassSpringMaterial.isotropic(3.0e4)),
        TissueVariant("mass_spring_anisotropic", "mass-spring anisotropic linear 24/16 kPa",
                    MassSpringMaterial.transversely_isotropic(el, et)),
        TissueVariant("mass_spring_nonlinear_anisotropic",
                    "mass-spring non-linear anisotropic (default meat)", meat),
        TissueVariant("mass_spring_nonlinear_anisotropic_implicit",
                      "mass-spring non-linear anisotropic (default meat), implicit step", meat,
                      "implicit"),
    )


def paper_fig10_material(damping_s: float = 2.0e-4) -> MassSpringMaterial:
    """The paper's Fig. 10 test material: El = 0.25 MPa, Et = Er = 0.6 MPa, linear springs,
    fibres along x, the given damping time (s; see :func:`paper_damping_s`).

    Example:
        >>> paper_fig10_material().transverse.small_strain_modulus_pa
        600000.0
    """
    return MassSpringMaterial.transversely_isotropic(0.25e6, 0.6e6, damping_s=damping_s)


def paper_damping_s(material: MassSpringMaterial, cell_size_m: float) -> float:
    """The paper's D = 0.1 N s/m per spring as this material's damping time on the muscles of
    ``cell_size_m`` (s): D over the median spring stiffness (``damping_s = D / K``).

    Example:
        >>> round(paper_damping_s(paper_fig10_material(), 0.04), 7)
        2.82e-05
    """
    run = tissue_run(bench_scenario(material, cell_size_m))
    stiffness = np.concatenate([springs.stiffness_n_m for springs in run.springs.values()])
    return PAPER_SPRING_DAMPING_N_S_M / float(np.median(stiffness))


def bench_scenario(material: ContinuumMaterial | MassSpringMaterial, cell_size_m: float,
                   tissue_step: Literal["implicit", "explicit"] = "explicit") -> Scenario:
    """The default scenario with this material, mesh and tissue step; the bench sets the
    explicit step per run, the implicit one runs at the scenario's default step.

    Example:
        >>> bench_scenario(ContinuumMaterial(), 0.05).tissue.cell_size_m
        0.05
    """
    simulation = (SimulationParams(tissue_step="implicit") if tissue_step == "implicit"
                  else SimulationParams(timestep_s=0.002, tissue_step="explicit"))
    return Scenario(tissue=MuscleShape(cell_size_m=cell_size_m), material=material,
                    simulation=simulation)


def tissue_run(scenario: Scenario) -> TissueSimulation:
    """The cell's physics step on the muscles of ``scenario`` without the robots.

    Example:
        >>> tissue_run(bench_scenario(ContinuumMaterial(), 0.05)).scene.node_count
        240
    """
    return TissueSimulation(build_scene(scenario, robots=False), scenario)
