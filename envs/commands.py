"""Tool targets integrated from velocity actions: the knife in its path's frame, the grasp site
in the world frame, each kept within its bounds."""

from __future__ import annotations

import numpy as np

from controllers.knife import CutWindow
from controllers.trajectory import CartesianTrajectory
from envs.params import ActionLimits

Pose = tuple[np.ndarray, np.ndarray]
"""A position (3,) m and a rotation (3, 3) in the world frame."""


def _yaw(angle_rad: float) -> np.ndarray:
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class KnifeCommand:
    """The knife tip's target: a point of the planned cut plus offsets in the path's frame.

    The frame at path parameter ``tau_s`` is the planned tip pose there: x along the cutting
    edge (the path's tangent), y across (the blade's normal), z down the blade's axis. ``tau_s``
    is the planned trajectory's time, so that moving along at the plan's own speed replays
    the plan; it stays within the cut window.

    Args:
        trajectory: the planned knife trajectory (:attr:`cell.sim.episode.EpisodePlan.knife`).
        window_s: its cutting window, s.
        speed_m_s: the plan's cutting speed.
        limits: speeds and bounds.

    Example:
        >>> from cell.sim.episode import Episode
        >>> from cell.sim.scenario import Scenario
        >>> from cell.tissue.geometry import MuscleShape
        >>> episode = Episode(Scenario(tissue=MuscleShape(cell_size_m=0.05)))
        >>> plan = episode.plan()
        >>> command = KnifeCommand(plan.knife, plan.cut_window_s, 0.03, ActionLimits())
        >>> (position_m, rotation), bounded = command.advance(np.array([0.4, 0, 0, 0]), 0.02)
        >>> command.progress > 0.0, bounded
        (True, 0)
    """

    def __init__(self, trajectory: CartesianTrajectory, window_s: CutWindow,
                 speed_m_s: float, limits: ActionLimits) -> None:
        self.trajectory = trajectory
        self.window_s = window_s
        self.speed_m_s = speed_m_s
        self.limits = limits
        self.tau_s = window_s.start_s
        self.across_m = 0.0
        self.depth_m = 0.0
        self.yaw_rad = 0.0

    @property
    def progress(self) -> float:
        """Fraction of the cut window reached, in [0, 1]."""
        start, end = self.window_s
        return (self.tau_s - start) / (end - start)

    def path_pose(self, tau_s: float | None = None) -> Pose:
        """The planned tip pose at ``tau_s`` (now by default), clamped to the window."""
        tau = self.tau_s if tau_s is None else tau_s
        return self.trajectory.sample(float(np.clip(tau, *self.window_s)))

    def target(self) -> Pose:
        """The tip target now: the path's pose moved by the offsets."""
        position, rotation = self.path_pose()
        position = position + self.across_m * rotation[:, 1] + self.depth_m * rotation[:, 2]
        return position, rotation @ _yaw(self.yaw_rad)

    def advance(self, action: np.ndarray, dt_s: float) -> tuple[Pose, int]:
        """Move by ``action`` = (along, across, depth, yaw rate) in [-1, 1] for ``dt_s``;
        returns the new target and how many of the four hit their bound."""
        lim = self.limits
        tau = self.tau_s + action[0] * lim.knife_along_speed_m_s / self.speed_m_s * dt_s
        wanted = np.array([tau,
                           self.across_m + action[1] * lim.knife_across_speed_m_s * dt_s,
                           self.depth_m + action[2] * lim.knife_depth_speed_m_s * dt_s,
                           self.yaw_rad + action[3] * lim.knife_yaw_rate_rad_s * dt_s])
        low = np.array([self.window_s.start_s, -lim.knife_max_across_m, -lim.knife_max_depth_m,
                        -lim.knife_max_yaw_rad])
        high = np.array([self.window_s.end_s, lim.knife_max_across_m, lim.knife_max_depth_m,
                         lim.knife_max_yaw_rad])
        bounded = np.clip(wanted, low, high)
        self.tau_s, self.across_m, self.depth_m, self.yaw_rad = map(float, bounded)
        return self.target(), int(np.count_nonzero(bounded != wanted))

    def follow(self, t_s: float) -> None:
        """Put the path's parameter where the scripted knife is at ``t_s`` (within the window),
        so that a policy of the pull sees the knife's progress."""
        self.tau_s = float(np.clip(t_s, *self.window_s))

    def offsets(self) -> np.ndarray:
        """(across m, depth m, yaw rad) now."""
        return np.array([self.across_m, self.depth_m, self.yaw_rad])


class PullCommand:
    """The grasp site's target: the grasp point plus a displacement the pull velocity
    integrates, within ``pull_max_distance_m`` of it and at most ``pull_max_sink_m`` below.

    Example:
        >>> command = PullCommand(np.zeros(3), np.eye(3), ActionLimits())
        >>> (position_m, rotation), bounded = command.advance(np.array([0.0, 1.0, -1.0]), 0.02)
        >>> position_m, bounded
        (array([ 0.   ,  0.001, -0.001]), 0)
    """

    def __init__(self, origin_m: np.ndarray, rotation: np.ndarray,
                 limits: ActionLimits) -> None:
        self.origin_m = np.asarray(origin_m, float)
        self.rotation = np.asarray(rotation, float)
        self.limits = limits
        self.displacement_m = np.zeros(3)

    def target(self) -> Pose:
        """The grasp site's target now."""
        return self.origin_m + self.displacement_m, self.rotation

    def advance(self, action: np.ndarray, dt_s: float) -> tuple[Pose, int]:
        """Move at ``action`` (3,) in [-1, 1] times the pull speed for ``dt_s``; returns the
        new target and whether the bounds held it back (0 or 1)."""
        lim = self.limits
        wanted = self.displacement_m + np.asarray(action, float) * lim.pull_speed_m_s * dt_s
        bounded = wanted.copy()
        bounded[2] = max(bounded[2], -lim.pull_max_sink_m)
        distance = float(np.linalg.norm(bounded))
        if distance > lim.pull_max_distance_m:
            bounded *= lim.pull_max_distance_m / distance
        self.displacement_m = bounded
        return self.target(), int(not np.array_equal(bounded, wanted))
