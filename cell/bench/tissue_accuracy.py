"""The tissue bench's realism figure: a tension test on a cube, and its extrapolation to the
converged force."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import mujoco
import numpy as np
from scipy.optimize import brentq

from cell.sim.assembly import integrator
from cell.sim.scenario import Scenario
from cell.tissue.flexcomp import flexcomp_xml, set_continuum_law
from cell.tissue.massspring import MassSpringModel
from cell.tissue.material import ContinuumMaterial, MassSpringMaterial
from cell.tissue.tetmesh import TetMesh, structured_hex_tets

# Mass given to the displaced face of the tension test: the solver then cannot move it.
_HELD_MASS_KG = 1e6


def _cube(cells: int, side_m: float) -> TetMesh:
    axis = np.linspace(0.0, side_m, cells + 1)
    grid = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
    return TetMesh.from_arrays(grid, structured_hex_tets((cells, cells, cells)), "tension cube")


def _stiffest_modulus_pa(material: ContinuumMaterial | MassSpringMaterial) -> float:
    if isinstance(material, ContinuumMaterial):
        return material.young_pa
    return max(material.longitudinal.max_modulus_pa(), material.transverse.max_modulus_pa())


def tension_force_n(material: ContinuumMaterial | MassSpringMaterial, cells: int,
                    side_m: float = 0.1, strain: float = 0.1) -> float:
    """Reaction force (N) of a cube pulled ``strain`` of its height along z, quasi-statically.

    The cube (``cells`` per edge, mirrored Kuhn tets) has its bottom face pinned and its top
    face clamped and moved up, no gravity; mass-spring fibres run along the pull. The top
    vertices get a huge mass (the implicit solver of ``discrete`` then leaves them where they
    are put) and are moved along a ramp; dof damping, critical for the cube's first mode,
    settles the rest (it leaves the static state alone). The force is the elastic force on
    the top face at rest: the springs' share of ``qfrc_applied`` for the mass-spring model,
    ``qfrc_spring`` for MuJoCo's flex elasticity.

    Example:
        >>> round(tension_force_n(ContinuumMaterial(), 2), 1)
        53.7
    """
    if isinstance(material, MassSpringMaterial):
        material = replace(material, fibre_direction=(0.0, 0.0, 1.0))
    mesh = _cube(cells, side_m)
    z = mesh.points[:, 2]
    bottom = np.flatnonzero(z < 1e-9 * side_m)
    top = np.flatnonzero(z > side_m * (1.0 - 1e-9))
    flex = flexcomp_xml("cube", mesh.points, mesh.tets, material,
                        material.density_kg_m3 * mesh.volume_m3, radius_m=0.0005,
                        contact='contype="0" conaffinity="0"', pins=bottom.tolist())
    spec = mujoco.MjSpec.from_string(
        f'<mujoco><option gravity="0 0 0"/><worldbody>{flex}</worldbody></mujoco>')
    set_continuum_law(spec, material)
    spec.option.integrator = integrator(Scenario(material=material))
    model = spec.compile()
    springs = (MassSpringModel(model, ("cube",), material)
               if isinstance(material, MassSpringMaterial) else None)
    omega = math.pi * math.sqrt(_stiffest_modulus_pa(material) / material.density_kg_m3) / side_m
    # The continuum runs implicitly (any step); the springs at their stable step.
    model.opt.timestep = 0.2 / omega if springs is None else springs.stable_timestep_s()
    model.dof_damping[:] = 2.0 * omega * model.body_mass[model.dof_bodyid]
    held = np.array([model.body(f"cube_{i}").id for i in top])
    model.body_mass[held] = _HELD_MASS_KG
    data = mujoco.MjData(model)
    mujoco.mj_setConst(model, data)
    qpos = model.jnt_qposadr[model.body_jntadr[held]] + 2
    dofs = model.body_dofadr[held][:, None] + np.arange(3)
    ramp_s, hold_s = 10.0 / omega, 15.0 / omega
    steps = math.ceil((ramp_s + hold_s) / model.opt.timestep)
    for k in range(steps + 1):
        data.qpos[qpos] = strain * side_m * min(1.0, k * model.opt.timestep / ramp_s)
        data.qvel[dofs] = 0.0
        if springs is not None:
            springs.apply(data)
        if k < steps:
            mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    return float(-(data.qfrc_applied + data.qfrc_spring)[dofs[:, 2]].sum())


def extrapolated_force_n(forces: dict[int, float]) -> tuple[float, float | None]:
    """Richardson extrapolation of forces on three meshes (cells per edge -> N) to zero cell
    size, with the convergence order fitted to them; returns the limit and the order.

    Falls back to the finest force (order None) where the three are not in the asymptotic
    range (not monotone, or not shrinking).

    Example:
        >>> f = {n: 40.0 + 12.0 / n for n in (8, 12, 16)}
        >>> [round(v, 6) for v in extrapolated_force_n(f)]
        [40.0, 1.0]
    """
    (na, fa), (nb, fb), (nc, fc) = sorted(forces.items())
    d1, d2 = fa - fb, fb - fc
    if d1 * d2 <= 0.0:
        return fc, None

    def mismatch(order: float) -> float:
        return (na**-order - nb**-order) / (nb**-order - nc**-order) - d1 / d2

    low, high = 0.05, 8.0
    if mismatch(low) * mismatch(high) > 0.0:
        return fc, None
    order = brentq(mismatch, low, high, xtol=1e-12)
    # The finest mesh's own error, c nc**-order, is d2 / ((nc / nb)**order - 1).
    return fc - d2 / ((nc / nb) ** order - 1.0), order


def _cells_per_edge(cell_size_m: float, side_m: float) -> int:
    return max(1, round(side_m / cell_size_m))


def force_errors(material: ContinuumMaterial | MassSpringMaterial,
                 cell_sizes_m: tuple[float, ...], reference_cells: tuple[int, int, int],
                 side_m: float = 0.1, strain: float = 0.1) -> dict[str, Any]:
    """The tension test's reference for ``material`` (extrapolated from ``reference_cells``
    cells per edge) and its force and error at every cell size of ``cell_sizes_m``.

    Example:
        >>> entry = force_errors(ContinuumMaterial(), (0.05,), (2, 3, 4))
        >>> sorted(entry["force_error_pct"])
        ['0.05']
    """
    sizes = {c: _cells_per_edge(c, side_m) for c in cell_sizes_m}
    forces = {n: tension_force_n(material, n, side_m, strain)
              for n in sorted({*reference_cells, *sizes.values()})}
    fine = sorted(reference_cells)
    reference, order = extrapolated_force_n({n: forces[n] for n in fine})
    # Without a fitted order, the last refinement's change bounds the finest mesh's error.
    finest_error = abs(forces[fine[2]] - (reference if order is not None else forces[fine[1]]))
    return {
        "reference_force_n": reference,
        "reference": f"Richardson extrapolation of the same model on {reference_cells} "
                     "cells per edge",
        "why": "each model against its own converged limit measures the error of this mesh "
               "alone; a common reference would add each model's own error (a spring "
               "lattice's fixed Poisson ratio, StVK against neo-Hookean), which the reference "
               "forces of the models show instead",
        "convergence_order": order,
        "finest_mesh_error_pct": finest_error / abs(reference) * 100.0,
        "force_n": {str(n): f for n, f in forces.items()},
        "force_error_pct": {
            str(c): abs(forces[n] - reference) / reference * 100.0 for c, n in sizes.items()},
    }

