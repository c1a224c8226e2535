"""One physics step: the tissue bench's run on the muscles alone and the cell's simulation
write the same tissue forces, and a reset puts the springs' history back at rest."""

from __future__ import annotations

import mujoco
import numpy as np

from cell.bench.tissue_variants import bench_scenario, tissue_run
from cell.sim.assembly import build_scene
from cell.sim.simulation import Simulation
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
