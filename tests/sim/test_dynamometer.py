"""The fixture's dynamometer and the tools' force sensors read what acts on them: known loads
(the tissue's weight, a pull through the bindings, a knife pressing on the round, a pull on
the grasped shank) against the readings, averaged over control steps (the vertices' own
vibration shakes a single reading by a newton or so)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from cell.bench.cell import contact_state, per_contact_load
from cell.perception.params import PerceptionParams
from cell.robots.names import GRASP_SITE, KNIFE_TIP
from cell.sim.assembly import build_scene
from cell.sim.dynamometer import contact_forces, contact_load
from cell.sim.episode import TARE_LEAD_S, Episode
from cell.sim.scenario import Scenario, SensorParams
from cell.sim.simulation import Simulation
from cell.tissue.geometry import MuscleShape

STEPS = 5  # physics steps between two readings


def _coarse(**changes: object) -> Scenario:
    scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05),
                        perception=PerceptionParams(enabled=False),
                        sensors=SensorParams(force_noise_n=0.0, torque_noise_nm=0.0))
    return replace(scenario, **changes)


def _mean(advance: Callable[[], None], reading: Callable[[], np.ndarray], count: int = 25
          ) -> np.ndarray:
    values = []
    for _ in range(count):
        advance()
        values.append(reading())
    return np.mean(values, axis=0)


def _fixture(sim: Simulation) -> np.ndarray:
    """The dynamometer untared: what the world gives the fixture to hold the round, N."""
    return sim.read("fixture_force") + sim._tare["fixture_force"]


def test_the_dynamometer_carries_the_rounds_weight_at_rest() -> None:
    scenario = _coarse()
    sim = Simulation(build_scene(scenario), scenario)
    sim.step(200)
    weight_n = sim.model.body_subtreemass[sim.model.body("fixture").id] * 9.81
    reading = _mean(lambda: sim.step(STEPS), lambda: _fixture(sim))
    assert reading == pytest.approx([0.0, 0.0, weight_n], abs=0.02 * weight_n)


def test_the_dynamometer_reads_a_pull_through_the_bindings() -> None:
    # Without gravity, a steady 5 N up on the shank hangs on the bindings alone, so the
    # round pulls the fixture up by 5 N; MuJoCo's own sensor misses it (the bindings are
    # forces on the vertices' joints, not external loads).
    scenario = _coarse()
    scenario = replace(scenario, aponeurosis=replace(scenario.aponeurosis, damping_n_s_m=5.0))
    sim = Simulation(build_scene(scenario), scenario)
    sim.model.opt.gravity[:] = 0.0
    sim.step(100)
    shank = np.unique(sim.scene.shank_bodies)
    sim.data.xfrc_applied[shank, 2] = 5.0 / len(shank)
    sim.step(600)
    reading = _mean(lambda: sim.step(STEPS), lambda: _fixture(sim), 50)
    mujoco_sensor = _mean(lambda: sim.step(STEPS),
                          lambda: sim.data.sensordata[sim._sensor["fixture_force"]].copy(), 50)
    assert reading == pytest.approx([0.0, 0.0, -5.0], abs=0.25)
    assert abs(mujoco_sensor[2]) < 0.5


def test_a_knife_pressing_on_the_round_loads_the_fixture_as_it_reads() -> None:
    episode = Episode(_coarse())
    plan, sim = episode.plan(), episode.sim
    start, rotation = episode.ik.site_pose(KNIFE_TIP)
    points = episode.scene.mesh.round.points
    near = points[np.linalg.norm(points[:, :2] - [-0.1, -0.06], axis=1) < 0.04]
    above = np.array([-0.1, -0.06, near[:, 2].max() + 0.02])
    pressed = above - [0.0, 0.0, 0.035]

    def move(a: np.ndarray, b: np.ndarray, duration_s: float) -> None:
        begin = sim.time_s
        while sim.time_s < begin + duration_s - 1e-9:
            share = min(1.0, (sim.time_s + episode.control_dt_s - begin) / duration_s)
            episode.control_step(plan, (a + share * (b - a), rotation), None)

    def hold(at: np.ndarray) -> Callable[[], None]:
        return lambda: episode.control_step(plan, (at, rotation), None)

    def both() -> np.ndarray:
        return np.concatenate([_fixture(sim), sim.read_world("knife/force")])

    # All before the plan's cut, when the episode tares the knife again and cuts.
    move(start, above, 0.6)
    before = _mean(hold(above), both)
    move(above, pressed, 0.8)
    fixture, push = np.split(_mean(hold(pressed), both) - before, 2)
    assert sim.time_s < plan.cut_window_s.start_s - 0.1
    # The knife's sensor reads its push on the flesh; the fixture holds it up.
    assert push[2] < -2.0
    assert np.linalg.norm(fixture + push) < 0.15 * np.linalg.norm(push)


def test_the_grippers_zero_holds_its_weight_not_the_inertia_of_its_stop() -> None:
    # The gripper is tared on its way to the grasp (TARE_LEAD_S before its jaws close), not as
    # it stops there: at rest with its jaws closed on nothing it then reads nothing, where a
    # zero taken in its stop read the stop's inertial load (3.5 N) until the end.
    episode = Episode(_coarse())
    plan, sim = episode.plan(), episode.sim
    schedule = plan.schedule
    site = sim.model.sensor("gripper/force").objid[0]
    weight_n = sim.model.body_subtreemass[sim.model.site_bodyid[site]] * 9.81
    untared, at_rest = [], []
    while sim.time_s < schedule.grasp_s - 2 * episode.control_dt_s:
        episode.control_step(plan, None, plan.pull.sample(sim.time_s + episode.control_dt_s))
        if sim.time_s < schedule.close_s - TARE_LEAD_S - episode.control_dt_s:
            untared.append(np.linalg.norm(sim.read("gripper/force")))
        elif sim.time_s > schedule.close_s + TARE_LEAD_S:
            at_rest.append(np.linalg.norm(sim.read("gripper/force")))
    assert np.mean(untared[-10:]) == pytest.approx(weight_n, rel=0.02)
    assert len(at_rest) >= 5 and max(at_rest) < 0.1


def _grasp_force(sim: Simulation) -> np.ndarray:
    """The force the grasp's constraints put on the gripper, world frame, N (their three
    rows each are world axes)."""
    data = sim.data
    rows = np.flatnonzero((data.efc_type[:data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY)
                          & np.isin(data.efc_id[:data.nefc], sim.grasped))
    return data.efc_force[rows].reshape(-1, 3).sum(axis=0)


@pytest.mark.slow
def test_the_gripper_reads_the_pull_of_the_grasped_shank() -> None:
    episode = Episode(_coarse())
    plan, sim = episode.plan(), episode.sim
    while sim.time_s < plan.schedule.grasp_s + 0.05:
        episode.control_step(plan, None, plan.pull.sample(sim.time_s + episode.control_dt_s))
    assert len(sim.grasped) > 0
    position, rotation = episode.ik.site_pose(GRASP_SITE)

    def hold() -> None:
        episode.control_step(plan, None, (position + np.array([0.0, 0.0, 0.03]), rotation))

    def both() -> np.ndarray:
        return np.concatenate([_grasp_force(sim), sim.read_world("gripper/force")])

    for _ in range(25):
        hold()
    before = _mean(hold, both)
    shank = np.unique(episode.scene.shank_bodies)
    sim.data.xfrc_applied[shank, 2] = 3.0 / len(shank)
    for _ in range(25):
        hold()
    grasp, reading = np.split(_mean(hold, both) - before, 2)
    # The shank pulls the gripper, which pulls on the sensor: minus.
    assert np.linalg.norm(grasp) > 1.0
    assert np.linalg.norm(reading + grasp) < 0.1 * np.linalg.norm(grasp)


@pytest.mark.slow  # a whole episode
def test_the_contact_loads_read_at_once_equal_mujocos_per_contact_forces() -> None:
    # In the cut: the blade, the table and the fixture touch many flex vertices.
    sim = contact_state(_coarse()).sim
    model, data = sim.model, sim.data
    count = data.ncon
    assert count > 20
    wrench = np.zeros(6)
    expected = []
    for i in range(count):
        mujoco.mj_contactForce(model, data, i, wrench)
        expected.append(wrench[:3].copy())
    assert contact_forces(model, data, np.arange(count)) == pytest.approx(
        np.array(expected), rel=1e-12, abs=1e-12)
    knife = sim._tool_sensor["knife/force"][1]
    on_knife = np.isin(model.geom_bodyid[np.maximum(data.contact.geom[:count], 0)], knife)
    on_round = data.contact.flex[:count] == sim.dynamometer.round_flex
    for on_object in (on_knife & (data.contact.geom[:count] >= 0), on_round):
        assert (on_object[:, 0] != on_object[:, 1]).any()
        point_m = data.xpos[1]
        for load, reference in zip(contact_load(model, data, on_object, point_m),
                                   per_contact_load(model, data, on_object, point_m),
                                   strict=True):
            assert load == pytest.approx(reference, rel=1e-12, abs=1e-12)
