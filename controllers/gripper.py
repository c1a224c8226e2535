"""The gripper controller's plan: reach the shank, close, grasp, then pull it off the round."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell.scenario import PullPlan
from controllers.knife import APPROACH_SPEED_M_S, TRANSIT_SPEED_M_S
from controllers.trajectory import CartesianTrajectory, Waypoint

#: Jaws pointing straight down, opening across the muscles (world y).
_JAWS_DOWN = np.column_stack([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]])
#: Back-off along the tool axis from the grasp point to the waiting pose, beyond the depth, m.
_APPROACH_M = 0.08
#: Time for the fingers to close before the grasp bindings are switched on, s.
CLOSE_TIME_S = 0.3


@dataclass(frozen=True)
class PullSchedule:
    """When the gripper closes, grasps, starts and ends the pull (s)."""

    close_s: float
    grasp_s: float
    pull_start_s: float
    pull_end_s: float


def grasp_rotation(plan: PullPlan) -> np.ndarray:
    """Jaws down, leaning ``tilt_deg`` about world x so that the tool axis points toward the
    interface (-y)."""
    tilt = np.deg2rad(plan.tilt_deg)
    c, s = np.cos(tilt), np.sin(tilt)
    lean = np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])
    return lean @ _JAWS_DOWN


def ready_pose(grasp_point_m: np.ndarray, plan: PullPlan) -> tuple[np.ndarray, np.ndarray]:
    """Grasp-site pose (m, rotation) backed off along the tool axis, where the gripper waits."""
    rotation = grasp_rotation(plan)
    return grasp_point_m - (plan.grasp_depth_m + _APPROACH_M) * rotation[:, 2], rotation


def plan_pull(grasp_point_m: np.ndarray, plan: PullPlan, start_s: float,
              cut_window_s: tuple[float, float], start_pos: np.ndarray,
              start_rot: np.ndarray) -> tuple[CartesianTrajectory, PullSchedule]:
    """Grasp-site trajectory: above the grasp point, down to it, hold while the jaws close,
    pull ``tension_m`` while the knife cuts (``cut_window_s``), then on to ``distance_m`` along
    ``direction`` at ``speed_m_s``."""
    above, rotation = ready_pose(grasp_point_m, plan)
    direction = np.asarray(plan.direction, float)
    direction /= np.linalg.norm(direction)
    reach = [
        Waypoint(above, rotation, TRANSIT_SPEED_M_S, dwell_s=0.2),
        Waypoint(grasp_point_m, rotation, APPROACH_SPEED_M_S),
    ]
    close_s = CartesianTrajectory(start_s, start_pos, start_rot, reach).end_s
    grasp_s = close_s + CLOSE_TIME_S
    cut_start, cut_end = cut_window_s
    pull_start = max(cut_start + plan.start_delay_s, grasp_s + 0.2)
    tension_s = max(cut_end - pull_start, 0.1)
    reach[-1] = Waypoint(grasp_point_m, rotation, APPROACH_SPEED_M_S,
                         dwell_s=pull_start - close_s)
    tensioned = grasp_point_m + plan.tension_m * direction
    waypoints = [
        *reach,
        Waypoint(tensioned, rotation, max(plan.tension_m, 1e-6) / tension_s),
        Waypoint(grasp_point_m + plan.distance_m * direction, rotation,
                 plan.speed_m_s),
    ]
    trajectory = CartesianTrajectory(start_s, start_pos, start_rot, waypoints)
    return trajectory, PullSchedule(close_s, grasp_s, pull_start, trajectory.end_s)
