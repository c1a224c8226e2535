"""Whether the arms can follow a plan, checked before any simulation: each tool's waypoints
(the ready pose, then every knot of the knife's and the gripper's trajectories) solved by IK,
kinematics only, on a copy of the arms; a waypoint the tool cannot reach within the joint
limits raises :class:`~cell.errors.ReachError` naming the arm, the waypoint and the joint at
its limit (or, for a target beyond the arm's reach, the joint nearest one).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import mink
import numpy as np

from cell.errors import ReachError
from cell.robots.choice import PLACES, CellArm, near_limit
from cell.robots.names import GRASP_SITE, KNIFE_TIP
from controllers.ik import CellIK, arm_joint_names
from controllers.trajectory import CartesianTrajectory

#: The tool site each arm's waypoints are given at, by place.
TOOL_SITES = {"knife": KNIFE_TIP, "gripper": GRASP_SITE, "camera": "camera/optical"}


@dataclass(frozen=True)
class ReachTolerance:
    """How close IK must bring a tool to a waypoint for the arm to reach it.

    Attributes:
        position_m: the largest distance left, m.
        angle_rad: the largest turn left, rad.
        iterations: IK steps toward each waypoint (from the last one's solution).
        step_s: the IK step, s (no speed limit: only whether the pose is reachable counts).

    Example:
        >>> ReachTolerance().position_m
        0.002
    """

    position_m: float = 0.002
    angle_rad: float = 0.02
    iterations: int = 60
    step_s: float = 0.1


def _miss(configuration: mink.Configuration, site: str, target: mink.SE3
          ) -> tuple[float, float]:
    """Distance (m) and turn (rad) left from ``site`` to ``target``."""
    now = configuration.get_transform_frame_to_world(site, "site")
    error = now.inverse() @ target
    return (float(np.linalg.norm(target.translation() - now.translation())),
            float(np.linalg.norm(error.rotation().log())))


def check_pose(configuration: mink.Configuration, place: str, arm: CellArm, target: mink.SE3,
               waypoint: str, tolerance: ReachTolerance = ReachTolerance()) -> None:
    """Raise :class:`ReachError` if the tool of ``place`` in ``configuration`` is not at
    ``target`` (``waypoint`` names it in the message)."""
    distance_m, turn_rad = _miss(configuration, TOOL_SITES[place], target)
    if distance_m <= tolerance.position_m and turn_rad <= tolerance.angle_rad:
        return
    names = arm_joint_names(PLACES[place], arm)
    model = configuration.model
    q = np.array([configuration.q[model.joint(name).qposadr[0]] for name in names])
    k = near_limit(arm, q)
    position = ", ".join(f"{v:.3f}" for v in target.translation())
    raise ReachError(None, f"arms.{place}",
                     f"{arm.name} cannot reach waypoint {waypoint} at ({position}) m within its "
                     f"joint limits: {distance_m * 1e3:.1f} mm and {np.degrees(turn_rad):.1f} "
                     f"deg short; joint {names[k]} at {q[k]:.3f} rad (limits "
                     f"{arm.lower_rad[k]:.3f} to {arm.upper_rad[k]:.3f}); move the arm's base "
                     "([layout]) or choose another arm")


def check_ready(ik: CellIK, arms: dict[str, CellArm]) -> None:
    """Raise :class:`ReachError` if IK left the knife, the gripper or the camera (its
    position: its gaze is a task of its own) short of its ready pose."""
    for place, task in (("knife", ik.knife), ("gripper", ik.grasp), ("camera", ik.camera)):
        tolerance = ReachTolerance(angle_rad=math.pi if place == "camera" else 0.02)
        check_pose(ik.configuration, place, arms[PLACES[place]],
                   task.transform_target_to_world, "ready (before the episode)", tolerance)


def _knots(trajectory: CartesianTrajectory) -> Iterator[tuple[str, mink.SE3]]:
    for k, time_s in enumerate(trajectory.arrivals_s):
        position_m, rotation = trajectory.sample(float(time_s))
        yield (f"{k + 1} (t = {time_s:.2f} s)",
               mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(rotation), position_m))


def check_plan(configuration: mink.Configuration, arms: dict[str, CellArm],
               trajectories: dict[str, CartesianTrajectory],
               tolerance: ReachTolerance = ReachTolerance()) -> None:
    """Solve each place's trajectory (``knife``, ``gripper``) waypoint by waypoint from
    ``configuration`` (left unchanged) and raise :class:`ReachError` at the first one missed.
    """
    for place, trajectory in trajectories.items():
        solving = mink.Configuration(configuration.model, configuration.q.copy())
        task = mink.FrameTask(TOOL_SITES[place], "site", position_cost=1.0,
                              orientation_cost=0.5)
        limits = [mink.ConfigurationLimit(solving.model)]
        arm = arms[PLACES[place]]
        for waypoint, target in _knots(trajectory):
            task.set_target(target)
            for _ in range(tolerance.iterations):
                if _miss(solving, TOOL_SITES[place], target)[0] < tolerance.position_m / 10:
                    break
                velocity = mink.solve_ik(solving, [task], tolerance.step_s, "daqp",
                                         damping=1e-3, limits=limits)
                solving.integrate_inplace(velocity, tolerance.step_s)
            check_pose(solving, place, arm, target, waypoint, tolerance)
