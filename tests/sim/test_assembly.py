"""The composed cell on a coarse tissue: actuators, sensors, equalities and flex vertices, the MJCF
export round trip, the camera's view of the meat at the episode's start, and divergence checks."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pytest

from cell.errors import DivergenceError
from cell.robots.camera import CameraRig
from cell.robots.names import CAMERA
from cell.sim.assembly import Scene, build_scene, export_mjcf
from cell.sim.episode import Episode
from cell.sim.scenario import AponeurosisParams, Scenario
from cell.sim.simulation import Simulation
from cell.tissue.aponeurosis import BindingLaw, ReleaseRule
from cell.tissue.geometry import MuscleShape

SCENARIO = Scenario(tissue=MuscleShape(cell_size_m=0.05))
SENSORS = {"knife/force", "knife/torque", "gripper/force", "gripper/torque", "fixture_force"}
ARM_JOINTS = {"knife_arm/": 6, "pull_arm/": 6, "camera_arm/": 7}


@pytest.fixture(scope="module")
def scene() -> Scene:
    return build_scene(SCENARIO)


@pytest.fixture(scope="module")
def episode() -> Episode:
    return Episode(SCENARIO)


def _names(model: mujoco.MjModel, obj: mujoco.mjtObj, count: int) -> list[str]:
    return [mujoco.mj_id2name(model, obj, i) for i in range(count)]


# --- composition ---------------------------------------------------------------------------------


def test_three_arms_and_two_fingers_are_actuated(scene: Scene) -> None:
    model = scene.model
    names = _names(model, mujoco.mjtObj.mjOBJ_ACTUATOR, model.nu)
    for prefix, joints in ARM_JOINTS.items():
        assert sum(n.startswith(prefix) for n in names) == joints, prefix
    fingers = [n for n in names if n.startswith("gripper/finger_")]
    assert sorted(fingers) == ["gripper/finger_left", "gripper/finger_right"]
    assert model.nu == 6 + 6 + 7 + 2
    for i, name in enumerate(names):
        assert model.actuator_trntype[i] == mujoco.mjtTrn.mjTRN_JOINT
        if not name.startswith("gripper/"):  # each arm servo drives the joint of its name
            assert model.joint(model.actuator_trnid[i, 0]).name == name


def test_force_torque_sensors_are_present(scene: Scene) -> None:
    model = scene.model
    assert set(_names(model, mujoco.mjtObj.mjOBJ_SENSOR, model.nsensor)) == SENSORS
    for name in SENSORS:
        assert model.sensor(name).dim[0] == 3


def test_spring_bindings_need_no_equalities(scene: Scene) -> None:
    assert scene.aponeurosis.law is BindingLaw.SPRING
    assert scene.model.neq == len(scene.grasp_equalities)
    assert len(scene.aponeurosis) == len(scene.mesh.pairs)


def test_one_binding_per_pair_and_inactive_grasp_equalities() -> None:
    scene = build_scene(replace(SCENARIO, aponeurosis=AponeurosisParams(
        law="constraint", release_rules=("knife", "tearing"))))
    model, apo = scene.model, scene.aponeurosis
    pairs = scene.mesh.pairs
    assert len(scene.grasp_equalities) > 0
    assert model.neq == len(pairs) + len(scene.grasp_equalities)
    assert len(apo.equality_ids) == len(pairs)
    assert model.eq_active0[apo.equality_ids].all()
    assert not model.eq_active0[scene.grasp_equalities].any()
    assert (model.eq_type == mujoco.mjtEq.mjEQ_CONNECT).all()
    # Each binding joins the round vertex and the shank vertex of its pair.
    np.testing.assert_array_equal(
        model.eq_obj1id[apo.equality_ids], scene.round_bodies[pairs[:, 0]]
    )
    np.testing.assert_array_equal(
        model.eq_obj2id[apo.equality_ids], scene.shank_bodies[pairs[:, 1]]
    )
    gripper = model.body("gripper/gripper").id
    assert (model.eq_obj1id[scene.grasp_equalities] == gripper).all()
    np.testing.assert_array_equal(
        model.eq_obj2id[scene.grasp_equalities], scene.shank_bodies[scene.grasp_vertices]
    )


def test_flex_vertices_are_the_tissue_nodes(scene: Scene) -> None:
    model, mesh = scene.model, scene.mesh
    assert model.nflex == 2
    assert scene.node_count == len(mesh.round.points) + len(mesh.shank.points)
    assert model.nflexvert == scene.node_count
    # The shank is free; the round is pinned to the holding plate along its bottom.
    fixture = model.body("fixture").id
    assert (model.body_dofnum[scene.shank_bodies] == 3).all()
    assert (scene.round_bodies == fixture).any()
    assert (model.body_dofnum[scene.round_bodies[scene.round_bodies != fixture]] == 3).all()


def test_exported_mjcf_compiles_to_the_same_model(scene: Scene, tmp_path: Path) -> None:
    path = export_mjcf(scene, tmp_path / "cell.xml")
    assert path == tmp_path / "cell.xml"
    assert [p.name for p in tmp_path.iterdir()] == ["cell.xml"]  # no temporary file left
    loaded = mujoco.MjModel.from_xml_path(str(path))
    model = scene.model
    for count in ("nbody", "njnt", "nu", "nflexvert", "neq", "nsensor", "nflex", "ngeom"):
        assert getattr(loaded, count) == getattr(model, count), count
    np.testing.assert_array_equal(loaded.eq_active0, model.eq_active0)
    np.testing.assert_allclose(loaded.qpos0, model.qpos0, atol=1e-6)


# --- camera at the episode's start ---------------------------------------------------------------


def test_camera_at_start_pose_sees_the_meat(episode: Episode) -> None:
    model, data = episode.scene.model, episode.sim.data
    rig = CameraRig(model, CAMERA, 320, 240)
    try:
        mask = rig.tissue_mask(data)
        depth = rig.depth(data)
        rgb = rig.rgb(data)
        cam_pos, cam_rot = rig.pose(data)
    finally:
        rig.close()
    assert mask.shape == (240, 320)
    assert mask.mean() >= 0.20
    assert depth.shape == (240, 320)
    assert rgb.shape == (240, 320, 3)
    tissue_depth = depth[mask]
    assert np.isfinite(tissue_depth).all()
    assert tissue_depth.min() > 0.2
    assert tissue_depth.max() < 3.0
    # The visible surface lies within the meat's hull, so its depth along the optical axis
    # (MuJoCo cameras look along -z) lies within that of the mesh vertices.
    points = np.concatenate([episode.scene.mesh.round.points, episode.scene.mesh.shank.points])
    vertex_depth = (points - cam_pos) @ -cam_rot[:, 2]
    assert tissue_depth.min() >= vertex_depth.min() - 0.01
    assert tissue_depth.max() <= vertex_depth.max() + 0.01
    # The meat is drawn red.
    red, green = rgb[mask][:, 0].astype(float), rgb[mask][:, 1].astype(float)
    assert red.mean() > green.mean() + 20


# --- divergence ----------------------------------------------------------------------------------


def _shank_body(scene: Scene) -> int:
    return int(scene.shank_bodies[len(scene.shank_bodies) // 2])


def _fresh_simulation(scene: Scene) -> Simulation:
    sim = Simulation(scene, SCENARIO)
    mujoco.mj_forward(sim.model, sim.data)
    return sim


def _assert_names_time_and_reason(error: DivergenceError, reason: str) -> None:
    assert reason in error.reason
    assert 0.0 < error.time_s <= 5 * SCENARIO.simulation.timestep_s + 1e-12
    assert f"t = {error.time_s:.4f} s" in str(error)
    assert error.reason in str(error)


def test_healthy_simulation_steps_without_divergence(scene: Scene) -> None:
    sim = _fresh_simulation(scene)
    sim.step(5)
    assert sim.time_s == pytest.approx(5 * SCENARIO.simulation.timestep_s)


def test_huge_force_on_the_tissue_is_a_divergence(scene: Scene) -> None:
    sim = _fresh_simulation(scene)
    sim.data.xfrc_applied[_shank_body(scene), :3] = [0.0, 0.0, 1e9]
    with pytest.raises(DivergenceError) as caught:
        sim.step(5)
    _assert_names_time_and_reason(caught.value, "MuJoCo warning mjWARN_BADQ")


def test_nan_velocity_is_a_divergence(scene: Scene) -> None:
    sim = _fresh_simulation(scene)
    sim.data.qvel[sim.model.body_dofadr[_shank_body(scene)]] = np.nan
    with pytest.raises(DivergenceError) as caught:
        sim.step(5)
    _assert_names_time_and_reason(caught.value, "MuJoCo warning mjWARN_BADQVEL")


def test_non_finite_state_is_a_divergence(scene: Scene) -> None:
    sim = _fresh_simulation(scene)
    model = sim.model
    sim.data.qpos[model.jnt_qposadr[model.body_jntadr[_shank_body(scene)]]] = np.inf
    with pytest.raises(DivergenceError, match="non-finite position or velocity"):
        sim.check_divergence()


def test_runaway_tissue_speed_is_a_divergence(scene: Scene) -> None:
    sim = _fresh_simulation(scene)
    limit = SCENARIO.simulation.max_tissue_speed_m_s
    sim.data.qvel[sim.model.body_dofadr[_shank_body(scene)]] = 5 * limit
    with pytest.raises(DivergenceError, match="tissue speed") as caught:
        sim.check_divergence()
    assert caught.value.time_s == 0.0
    sim.data.qvel[:] = 0.5 * limit  # below the limit is no divergence
    sim.check_divergence()


# --- reuse ---------------------------------------------------------------------------------------


def test_two_simulations_on_one_scene_start_identical() -> None:
    scene = build_scene(SCENARIO)
    first = Simulation(scene, SCENARIO)
    first.step(20)
    rested = first.data.qpos.copy()
    # What an episode leaves in the scene: grasp anchors in the model, a release record.
    assert first.grasp(np.full(3, 10.0)) > 0
    assert not np.array_equal(scene.model.eq_data, scene.eq_data0)
    apo = scene.aponeurosis
    apo.release(first.data, np.arange(len(apo)), first.time_s, ReleaseRule.KNIFE)
    second = Simulation(scene, SCENARIO)
    np.testing.assert_array_equal(scene.model.eq_data, scene.eq_data0)
    assert apo.bound.all() and not apo.hooked.any()
    second.step(20)
    np.testing.assert_array_equal(second.data.qpos, rested)


def test_a_reset_simulation_runs_as_a_new_one() -> None:
    scene = build_scene(SCENARIO)
    fresh = Simulation(scene, SCENARIO)
    fresh.step(20)
    expected = (fresh.data.qpos.copy(), fresh.read("knife/force"))
    sim = Simulation(scene, SCENARIO)
    sim.step(20)
    sim.tare("knife/force")
    assert sim.grasp(np.full(3, 10.0)) > 0
    sim.read("knife/force")  # draws noise
    sim.reset()
    assert len(sim.grasped) == 0
    sim.step(20)
    np.testing.assert_array_equal(sim.data.qpos, expected[0])
    np.testing.assert_array_equal(sim.read("knife/force"), expected[1])
