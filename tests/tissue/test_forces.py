"""One physics step: the tissue bench's run on the muscles alone and the cell's simulation
write the same tissue forces, a reset puts the springs' history back at rest, and the implicit
step runs the spring law once per control step at any timestep."""

from __future__ import annotations

from dataclasses import replace

import mujoco
import numpy as np
import pytest

import cell.tissue.massspring as massspring
from cell.bench.tissue_variants import bench_scenario, tissue_run
from cell.errors import ScenarioError
from cell.sim.assembly import build_scene
from cell.sim.scenario import Scenario, SimulationParams
from cell.sim.simulation import Simulation, TissueSimulation
from cell.tissue.curves import ModulusCurve
from cell.tissue.geometry import MuscleShape
from cell.tissue.material import MassSpringMaterial, default_meat


def test_the_bench_and_the_cell_write_the_same_tissue_forces() -> None:
    scenario = bench_scenario(default_meat(), 0.05)
    cell = Simulation(build_scene(scenario), scenario)
    bench = tissue_run(scenario)
    np.testing.assert_array_equal(cell.tissue.dofs, bench.tissue.dofs)
    dofs = cell.tissue.dofs
    cell.step(30)  # the muscles settle on the table: every spring and binding is loaded
    # Tissue vertices have slide joints only: their qpos and dof addresses agree.
    bench.data.qpos[dofs] = cell.data.qpos[dofs]
    bench.data.qvel[dofs] = cell.data.qvel[dofs]
    # The binding springs read the vertices' world positions: bring both up to date.
    mujoco.mj_forward(cell.model, cell.data)
    mujoco.mj_forward(bench.model, bench.data)
    cell.step()
    bench.step()
    forces = cell.data.qfrc_applied[dofs]
    assert np.abs(forces).max() > 0.0
    np.testing.assert_array_equal(bench.data.qfrc_applied[dofs], forces)


def test_a_reset_clears_the_springs_history() -> None:
    plastic = MassSpringMaterial.isotropic(3e4, yield_strain=1e-4, relaxation_weights=(0.5,),
                                           relaxation_times_s=(0.05,))
    run = tissue_run(bench_scenario(plastic, 0.05))
    run.step(40)
    first = run.data.qpos.copy()
    run.reset()
    run.step(40)
    np.testing.assert_array_equal(run.data.qpos, first)


def test_a_reset_to_a_state_starts_from_that_state() -> None:
    scenario = bench_scenario(MassSpringMaterial(), 0.05)
    run = tissue_run(scenario)
    run.step(10)
    state = run.data
    run.reset(state)
    assert run.data is not state
    np.testing.assert_array_equal(run.data.qpos, state.qpos)
    run.step(5)


def _stiffer(material: MassSpringMaterial, factor: float) -> MassSpringMaterial:
    """``material`` with every modulus curve ``factor`` times stiffer."""
    def scaled(curve: ModulusCurve) -> ModulusCurve:
        return replace(curve, coefficients=tuple(factor * c for c in curve.coefficients))
    return replace(material, longitudinal=scaled(material.longitudinal),
                   transverse=scaled(material.transverse))


def test_a_material_twenty_times_stiffer_runs_at_the_default_step() -> None:
    # Only the material changes: the implicit step keeps the scenario's step, which the
    # explicit step of the same springs would have to shorten several times.
    scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05),
                        material=_stiffer(default_meat(), 20.0))
    run = tissue_run(scenario)
    step = scenario.simulation.timestep_s
    explicit_limit = min(springs.stable_timestep_s() for springs in run.springs.values())
    assert explicit_limit < step / 2.0
    run.step(round(0.5 / step))  # the muscles settle on the table, no divergence
    assert np.abs(run.data.qvel[run.tissue.dofs]).max() < 0.5
    explicit = replace(scenario, simulation=replace(scenario.simulation,
                                                    tissue_step="explicit"))
    with pytest.raises(ScenarioError, match="stable step"):
        Simulation(build_scene(explicit), explicit)


@pytest.mark.parametrize(("timestep_s", "substeps"), [(0.0025, 8), (0.01, 2)])
def test_the_spring_law_runs_once_per_control_step(
        timestep_s: float, substeps: int, monkeypatch: pytest.MonkeyPatch) -> None:
    simulation = SimulationParams(timestep_s=timestep_s, control_rate_hz=50.0)
    assert simulation.control_substeps == substeps  # 20 ms control step
    scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05), simulation=simulation)
    sim = TissueSimulation(build_scene(scenario, robots=False), scenario)
    runs: list[bool] = []  # per kernel call (one per muscle and step): whether the law ran
    kernel = massspring.muscle_forces

    def spy(*args: object) -> None:
        runs.append(bool(args[-1]))
        kernel(*args)

    monkeypatch.setattr(massspring, "muscle_forces", spy)
    control_steps = 3
    sim.step(control_steps * substeps)
    muscles = len(sim.springs)
    per_step = np.array(runs).reshape(control_steps, substeps, muscles)
    assert per_step.sum(axis=1).tolist() == [[1] * muscles] * control_steps
    assert per_step[:, 0].all()  # at each control step's first physics step
