"""The gripper controller's plan: reach the shank, close, grasp, then pull it off the round."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell.config import require_non_negative, require_positive
from cell.errors import InputError
from controllers.knife import APPROACH_SPEED_M_S, TRANSIT_SPEED_M_S, CutWindow
from controllers.trajectory import CartesianTrajectory, Waypoint

#: Jaws pointing straight down, opening across the muscles (world y).
_JAWS_DOWN = np.column_stack([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]])
#: Back-off along the tool axis from the grasp point to the waiting pose, beyond the depth, m.
_APPROACH_M = 0.08
#: Time for the fingers to close before the grasp bindings are switched on, s.
CLOSE_TIME_S = 0.3


@dataclass(frozen=True)
class PullPlan:
    """How the gripper grasps the shank and pulls it away from the round.

    The grasp is at ``grasp_x_fraction`` of the length, ``grasp_inset_m`` in from the
    shank's outer side, jaws ``grasp_depth_m`` below its top. From ``start_delay_s`` after
    the cut starts until it ends, the gripper pulls ``tension_m`` along ``direction`` (world
    frame, normalised) to open the cut, as a butcher does; once the knife is out it pulls on to
    ``distance_m`` at ``speed_m_s``. The jaws lean ``tilt_deg`` toward the interface, which
    keeps the gripper's wrist clear of the knife. ``enabled = false`` keeps the gripper still.

    Example:
        >>> PullPlan(tilt_deg=30.0).distance_m
        0.16
        >>> PullPlan(tension_m=0.2)
        Traceback (most recent call last):
        cell.errors.InputError: tension_m: must be in [0, distance_m)
    """

    enabled: bool = True
    tilt_deg: float = 40.0
    grasp_x_fraction: float = 0.5
    grasp_inset_m: float = 0.035
    grasp_depth_m: float = 0.03
    grasp_radius_m: float = 0.03
    direction: tuple[float, float, float] = (0.0, 1.0, 0.6)
    tension_m: float = 0.006
    distance_m: float = 0.16
    speed_m_s: float = 0.02
    start_delay_s: float = 1.0

    def __post_init__(self) -> None:
        require_positive(self, "speed_m_s", "distance_m", "grasp_radius_m", "grasp_depth_m")
        require_non_negative(self, "start_delay_s", "grasp_inset_m")
        if not 0 <= self.grasp_x_fraction <= 1:
            raise InputError(None, "grasp_x_fraction", "must be in [0, 1]")
        if sum(c * c for c in self.direction) == 0:
            raise InputError(None, "direction", "must not be the zero vector")
        if not 0 <= self.tilt_deg <= 80:
            raise InputError(None, "tilt_deg", f"must be in [0, 80], got {self.tilt_deg}")
        if not 0 <= self.tension_m < self.distance_m:
            raise InputError(None, "tension_m", "must be in [0, distance_m)")


@dataclass(frozen=True)
class PullSchedule:
    """When the gripper closes, grasps, starts and ends the pull (s).

    Example:
        >>> PullSchedule(close_s=2.0, grasp_s=2.3, pull_start_s=4.0, pull_end_s=12.0).grasp_s
        2.3
    """

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
              cut_window_s: CutWindow, start_pos: np.ndarray,
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
