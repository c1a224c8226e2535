"""The runtime with each tissue model: it steps, it keeps the tissue on the table, and the
mass-spring fibres can be turned while it runs."""

from __future__ import annotations

from dataclasses import replace

import mujoco
import numpy as np
import pytest

from cell.errors import MaterialError, ScenarioError
from cell.sim.assembly import build_scene
from cell.sim.scenario import Scenario, SimulationParams
from cell.sim.simulation import Simulation
from cell.tissue.geometry import MuscleShape
from cell.tissue.material import ContinuumMaterial, MassSpringMaterial

COARSE = Scenario(tissue=MuscleShape(cell_size_m=0.05))


@pytest.mark.parametrize("material", [
    ContinuumMaterial(law="stvk"),
    ContinuumMaterial(law="neo_hookean"),
    ContinuumMaterial(yield_strain=0.05),
    MassSpringMaterial.isotropic(3e4),
    MassSpringMaterial.transversely_isotropic(2.5e4, 1.5e4),
], ids=["stvk", "neo-hookean", "plastic", "mass-spring-iso", "mass-spring-aniso"])
def test_every_tissue_model_rests_on_the_table(material: object) -> None:
    scenario = replace(COARSE, material=material)
    sim = Simulation(build_scene(scenario), scenario)
    sim.step(150)
    tissue = sim.data.flexvert_xpos
    assert np.isfinite(tissue).all()
    table = scenario.layout.table_height_m
    assert tissue[:, 2].min() > table - 0.005  # nothing sinks into the table
    assert tissue[:, 2].max() < table + scenario.tissue.round_height_m + 0.005


def test_turning_the_fibres_changes_the_springs_of_that_muscle_only() -> None:
    sim = Simulation(build_scene(COARSE), COARSE)
    round_before = sim.springs["round"].stiffness_n_m.copy()
    shank_before = sim.springs["shank"].stiffness_n_m.copy()
    sim.set_fibre_direction("round", np.array([0.0, 0.0, 1.0]))
    assert not np.allclose(sim.springs["round"].stiffness_n_m, round_before)
    np.testing.assert_array_equal(sim.springs["shank"].stiffness_n_m, shank_before)
    sim.step(20)
    with pytest.raises(MaterialError, match="fibre_direction"):
        sim.set_fibre_direction("round", np.zeros(3))


def test_a_timestep_above_the_springs_stable_step_is_refused_for_the_explicit_step() -> None:
    scenario = replace(COARSE, simulation=SimulationParams(timestep_s=0.02, control_rate_hz=25,
                                                           tissue_step="explicit"))
    with pytest.raises(ScenarioError, match=r"simulation\.timestep_s"):
        Simulation(build_scene(scenario), scenario)


def test_sensors_read_after_a_step_are_those_of_a_step_that_computes_them_every_time() -> None:
    scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05))
    sim = Simulation(build_scene(scenario), scenario)
    on_demand = []
    for _ in range(5):
        sim.step(4)  # MuJoCo's sensors run in the last of the four steps only
        on_demand.append(sim.data.sensordata.copy())
    sim.reset()
    every_step = []
    for _ in range(5):
        for _ in range(4):
            sim.model.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_SENSOR)
            sim.step(1)
        every_step.append(sim.data.sensordata.copy())
    assert np.abs(on_demand[-1]).max() > 0.0  # the arms' weight, at least
    assert all(np.array_equal(a, b) for a, b in zip(on_demand, every_step, strict=True))
