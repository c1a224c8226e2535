"""One mink IK problem for the whole cell: knife, gripper and camera arms solved together.

IK runs on the arms-only model (the tissue's thousands of vertex dofs would only inflate the
QP); its joints carry the same names as in the full scene, so the solution maps onto the
scene's position actuators by name.
"""

from __future__ import annotations

from dataclasses import dataclass

import mink
import mujoco
import numpy as np

from cell.robots.choice import CellArm
from cell.robots.names import GRASP_SITE, KNIFE_TIP


@dataclass(frozen=True)
class IKParams:
    """Weights and limits of the cell's IK.

    Costs are per task row (position in 1/m, orientation in 1/rad); ``speed_fraction`` scales
    every joint's rated maximum speed; ``solver`` is a qpsolvers name.

    Example:
        >>> IKParams(orientation_cost=0.2).solver
        'daqp'
    """

    position_cost: float = 1.0
    orientation_cost: float = 0.5
    look_cost: float = 0.5
    posture_cost: float = 1e-3
    damping: float = 1e-4
    speed_fraction: float = 0.5
    solver: str = "daqp"


class CellIK:
    """Differential IK of the knife tip, the grasp site and the camera's gaze.

    Args:
        model: the arms-only model (see :func:`cell.sim.assembly.build_robot_spec`).
        q0: starting configuration (nq,), e.g. every arm's home pose.
        arms: the cell's arms by prefix, for their rated speeds.
        params: costs, limits and solver.

    Example:
        >>> from cell.sim.assembly import build_robot_spec
        >>> from cell.sim.scenario import Scenario
        >>> robot_model = build_robot_spec(Scenario()).compile()
        >>> ik = CellIK(robot_model, robot_model.qpos0, Scenario().arms.cell_arms())
        >>> position_m, rotation = ik.site_pose(KNIFE_TIP)
        >>> ik.knife.set_target(pose(position_m + [0.0, 0.0, 0.01], rotation))
        >>> q = ik.solve(0.02)
        >>> bool(ik.site_pose(KNIFE_TIP)[0][2] > position_m[2])  # a step up towards it
        True
    """

    def __init__(self, model: mujoco.MjModel, q0: np.ndarray, arms: dict[str, CellArm],
                 params: IKParams = IKParams()) -> None:
        self.model = model
        self.params = params
        self.configuration = mink.Configuration(model, np.asarray(q0, float))
        self.knife = mink.FrameTask(KNIFE_TIP, "site", position_cost=params.position_cost,
                                    orientation_cost=params.orientation_cost)
        self.grasp = mink.FrameTask(GRASP_SITE, "site", position_cost=params.position_cost,
                                    orientation_cost=params.orientation_cost)
        self.gaze = mink.LookAtTask("camera/optical", "site", axis=(0.0, 0.0, 1.0),
                                    cost=params.look_cost)
        self.camera = mink.FrameTask("camera/optical", "site",
                                     position_cost=params.position_cost, orientation_cost=0.0)
        self.posture = mink.PostureTask(model, cost=params.posture_cost)
        self.posture.set_target(np.asarray(q0, float))
        self.tasks = [self.knife, self.grasp, self.gaze, self.camera, self.posture]
        speeds = {}
        for prefix, arm in arms.items():
            for name, speed in zip(arm_joint_names(prefix, arm), arm.max_speed_rad_s,
                                   strict=True):
                speeds[name] = params.speed_fraction * speed
        self.limits = [mink.ConfigurationLimit(model), mink.VelocityLimit(model, speeds)]
        tool_dofs = [model.jnt_dofadr[j] for j in range(model.njnt)
                     if model.joint(j).name not in speeds]
        self.constraints = [mink.DofFreezingTask(model, tool_dofs)] if tool_dofs else []
        for task in (self.knife, self.grasp, self.camera):
            task.set_target_from_configuration(self.configuration)
        eye, rotation = self.site_pose("camera/optical")
        self.gaze.set_target(eye + rotation[:, 2])

    def site_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """World position (3,) and rotation (3, 3) of a site in the IK configuration."""
        transform = self.configuration.get_transform_frame_to_world(name, "site")
        return transform.translation(), transform.rotation().as_matrix()

    def solve(self, dt_s: float) -> np.ndarray:
        """One IK step of ``dt_s``: returns the new joint positions (nq,)."""
        velocity = mink.solve_ik(self.configuration, self.tasks, dt_s, self.params.solver,
                                 damping=self.params.damping, limits=self.limits,
                                 constraints=self.constraints)
        self.configuration.integrate_inplace(velocity, dt_s)
        return self.configuration.q.copy()


def pose(position: np.ndarray, rotation: np.ndarray) -> mink.SE3:
    """A mink SE3 from a position (m) and a 3x3 rotation."""
    return mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(rotation),
                                                  np.asarray(position, float))


def arm_joint_names(prefix: str, arm: CellArm) -> list[str]:
    """Names of an arm's joints (and of their actuators) in the scene."""
    return [f"{prefix}/joint{i + 1}" for i in range(arm.dof)]
