"""An arm the project builds, written out as MJCF and as URDF and read back, is the same arm:
the flange in the same pose at any joint angles, the same limits, one servo a joint."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from cell.errors import InputError
from cell.robots.choice import cell_arm
from cell.robots.robotfile import load_robot_file
from tests.robotarms import UR5E, write_ur5e


def _flange_poses(model: mujoco.MjModel, angles: np.ndarray) -> list[np.ndarray]:
    data = mujoco.MjData(model)
    poses = []
    for q in angles:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        site = model.site("flange").id
        poses.append(np.concatenate([data.site_xpos[site], data.site_xmat[site]]))
    return poses


@pytest.mark.parametrize("kind", ["xml", "urdf"])
def test_dh_arm_round_trips_through_a_robot_file(tmp_path: Path, kind: str) -> None:
    built = cell_arm(UR5E).spec().compile()
    robot = load_robot_file(write_ur5e(tmp_path, kind), "flange")
    model = robot.spec.compile()
    assert model.nu == robot.dof == 6
    assert [model.actuator(k).name for k in range(6)] == [f"joint{k + 1}" for k in range(6)]
    angles = np.random.default_rng(0).uniform(-3.0, 3.0, size=(5, 6))
    for read, made in zip(_flange_poses(model, angles), _flange_poses(built, angles),
                          strict=True):
        np.testing.assert_allclose(read, made, atol=1e-6)
    np.testing.assert_allclose(robot.lower_rad, UR5E.lower_rad, atol=1e-5)
    if kind == "urdf":  # URDF carries the rated speeds; MJCF has no place for them
        assert robot.max_speed_rad_s == UR5E.max_speed_rad_s
    else:
        assert robot.max_speed_rad_s is None


def test_a_missing_flange_is_named(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="tool0") as refused:
        load_robot_file(write_ur5e(tmp_path, "xml"), "tool0")
    assert refused.value.field == "flange"


def test_a_file_mujoco_cannot_read_is_named(tmp_path: Path) -> None:
    path = tmp_path / "arm.xml"
    path.write_text("<mujoco><worldbody><body>")
    with pytest.raises(InputError, match="cannot read") as refused:
        load_robot_file(path, "flange")
    assert refused.value.field == "file"
