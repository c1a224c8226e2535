"""The arms built from their DH tables: kinematics, reach, servo hold, names, limits."""

from __future__ import annotations

import itertools
import math

import mujoco
import numpy as np
import pytest

from cell.errors import InputError
from cell.robots.arms import build_arm
from cell.robots.dh import KUKA_LWR4, VIPER_S1700D, ArmDescription
from cell.robots.servos import torque_limits_nm
from tests.kinematics import forward_kinematics

ARMS = [VIPER_S1700D, KUKA_LWR4]
TOOL_REACH_M = 0.2


def _random_configurations(arm: ArmDescription, count: int, seed: int) -> np.ndarray:
    lower = np.array([j.lower_rad for j in arm.joints])
    upper = np.array([j.upper_rad for j in arm.joints])
    return lower + (upper - lower) * np.random.default_rng(seed).random((count, arm.dof))


def _simulate(
    model: mujoco.MjModel,
    arm: ArmDescription,
    integrator: mujoco.mjtIntegrator,
    *,
    duration_s: float,
    tool_force_n: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Start at home with ctrl = home; return the flange position at the start and the end."""
    model.opt.timestep = 0.002
    model.opt.integrator = integrator
    data = mujoco.MjData(model)
    data.qpos[:] = arm.home_q_rad
    data.ctrl[:] = arm.home_q_rad
    mujoco.mj_forward(model, data)
    site = model.site("flange")
    start = data.site_xpos[site.id].copy()
    for _ in range(round(duration_s / model.opt.timestep)):
        if tool_force_n is not None:
            tool_point = data.site_xpos[site.id] + TOOL_REACH_M * data.site_xmat[site.id][2::3]
            data.qfrc_applied[:] = 0.0
            mujoco.mj_applyFT(
                model,
                data,
                tool_force_n,
                np.zeros(3),
                tool_point,
                site.bodyid[0],
                data.qfrc_applied,
            )
        mujoco.mj_step(model, data)
    assert np.all(np.isfinite(data.qpos))
    return start, data.site_xpos[site.id].copy()


@pytest.mark.parametrize("arm", ARMS, ids=lambda a: a.name)
def test_flange_site_matches_dh_forward_kinematics(arm: ArmDescription) -> None:
    model = build_arm(arm).compile()
    data = mujoco.MjData(model)
    site = model.site("flange").id
    for q in _random_configurations(arm, 50, seed=7):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        expected = forward_kinematics(arm, q)
        assert np.abs(data.site_xpos[site] - expected[:3, 3]).max() < 1e-9
        assert np.abs(data.site_xmat[site].reshape(3, 3) - expected[:3, :3]).max() < 1e-9


def test_viper_wrist_centre_reaches_1717_mm_and_no_further() -> None:
    arm = VIPER_S1700D
    model = build_arm(arm).compile()
    data = mujoco.MjData(model)
    # Link 5 sits at DH frame 4, the wrist centre.
    wrist = model.body("link5").id

    def horizontal_reach_m(q: np.ndarray) -> float:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        return float(np.hypot(*data.xpos[wrist][:2]))

    # Upper arm horizontal (q2 = 90 deg), forearm in line with it.
    stretched = np.array([0.0, math.pi / 2, -math.atan2(0.795, 0.140), 0.0, 0.0, 0.0])
    assert horizontal_reach_m(stretched) == pytest.approx(1.717, abs=1e-3)
    reaches = [horizontal_reach_m(q) for q in _random_configurations(arm, 500, seed=3)]
    assert max(reaches) <= 1.717 + 1e-3


@pytest.mark.parametrize(
    "integrator",
    [mujoco.mjtIntegrator.mjINT_DISCRETE, mujoco.mjtIntegrator.mjINT_IMPLICITFAST],
    ids=["discrete", "implicitfast"],
)
@pytest.mark.parametrize("arm", ARMS, ids=lambda a: a.name)
def test_arm_holds_home_under_gravity(arm: ArmDescription, integrator: int) -> None:
    start, end = _simulate(build_arm(arm).compile(), arm, integrator, duration_s=1.0)
    assert np.linalg.norm(end - start) < 2e-3


@pytest.mark.parametrize("arm", ARMS, ids=lambda a: a.name)
def test_flange_yields_under_1_mm_to_20_n_at_the_tool(arm: ArmDescription) -> None:
    model = build_arm(arm).compile()
    for direction in np.eye(3):
        start, end = _simulate(
            model,
            arm,
            mujoco.mjtIntegrator.mjINT_DISCRETE,
            duration_s=0.5,
            tool_force_n=20.0 * direction,
        )
        assert np.linalg.norm(end - start) < 1e-3


@pytest.mark.parametrize("arm", ARMS, ids=lambda a: a.name)
def test_no_contacts_at_home_and_neighbours_excluded(arm: ArmDescription) -> None:
    model = build_arm(arm).compile()
    data = mujoco.MjData(model)
    data.qpos[:] = arm.home_q_rad
    mujoco.mj_forward(model, data)
    assert data.ncon == 0
    excluded = {frozenset((int(s) >> 16, int(s) & 0xFFFF)) for s in model.exclude_signature}
    names = ["base"] + [f"link{i}" for i in range(1, arm.dof + 1)]
    for a, b in itertools.pairwise(names):
        assert frozenset((model.body(a).id, model.body(b).id)) in excluded


@pytest.mark.parametrize("arm", ARMS, ids=lambda a: a.name)
def test_limits_and_actuator_ranges_equal_the_dh_table(arm: ArmDescription) -> None:
    model = build_arm(arm).compile()
    table = np.array([[j.lower_rad, j.upper_rad] for j in arm.joints])
    torque = np.array(torque_limits_nm(arm))
    assert model.nu == arm.dof
    for i in range(1, arm.dof + 1):
        joint, actuator = model.joint(f"joint{i}"), model.actuator(f"joint{i}")
        assert joint.limited[0]
        assert actuator.trnid[0] == joint.id
        assert model.jnt_actgravcomp[joint.id]
        assert model.body_gravcomp[model.body(f"link{i}").id] == 1.0
    np.testing.assert_array_equal(model.jnt_range, table)
    np.testing.assert_array_equal(model.actuator_ctrlrange, table)
    assert model.actuator_ctrllimited.all() and model.actuator_forcelimited.all()
    np.testing.assert_array_equal(model.actuator_forcerange, np.stack([-torque, torque], 1))
    np.testing.assert_allclose(model.body_mass[model.body("link1").id :], arm.link_masses_kg)
    published = [j.max_torque_nm for j in arm.joints if j.max_torque_nm is not None]
    if published:
        np.testing.assert_array_equal(torque, published)


def test_arm_works_attached_under_a_prefix() -> None:
    arm = VIPER_S1700D
    parent = mujoco.MjSpec()
    frame = parent.worldbody.add_frame(pos=[1.0, -0.5, 0.2], euler=[0.0, 0.0, 0.3])
    parent.attach(build_arm(arm), frame=frame, prefix="knife_arm/")
    model = parent.compile()
    data = mujoco.MjData(model)
    data.qpos[:] = arm.home_q_rad
    mujoco.mj_kinematics(model, data)
    base = model.body("knife_arm/base").id
    site = model.site("knife_arm/flange").id
    local = data.xmat[base].reshape(3, 3).T @ (data.site_xpos[site] - data.xpos[base])
    np.testing.assert_allclose(local, forward_kinematics(arm, arm.home_q_rad)[:3, 3], atol=1e-9)
    assert model.actuator("knife_arm/joint3").trnid[0] == model.joint("knife_arm/joint3").id
    assert model.nexclude == build_arm(arm).compile().nexclude


def test_mismatched_arm_description_is_an_input_error() -> None:
    with pytest.raises(InputError):
        ArmDescription("bad", VIPER_S1700D.joints, 1.0, (1.0,), VIPER_S1700D.home_q_rad)


def test_one_stiffness_for_every_joint_scales_armature_and_damping() -> None:
    model = build_arm(KUKA_LWR4, stiffness_nm_per_rad=5000.0).compile()
    np.testing.assert_array_equal(model.actuator_gainprm[:, 0], 5000.0)
    # Armature bounds the servo frequency to omega_timestep / timestep = 250 rad/s.
    np.testing.assert_allclose(model.dof_armature, 5000.0 * (0.002 / 0.5) ** 2)
    np.testing.assert_allclose(model.dof_damping, 5000.0 * 0.001)
