"""Tool targets from actions: the knife's progress along its path from a speed, its offsets from
the path and the grasp site's displacement as places that the target moves to at its speed
limit.

Offsets are places, not velocities, because a policy learns by the noise on its actions: a
velocity's noise integrates into a random walk, so PPO exploring the depth by speed does not
find the table below the path (the design notes say how it failed), whereas a place's noise
averages out under the speed limit."""

from __future__ import annotations

import numpy as np

from controllers.knife import CutWindow
from controllers.trajectory import CartesianTrajectory
from envs.params import ActionLimits

Pose = tuple[np.ndarray, np.ndarray]
"""A position (3,) m and a rotation (3, 3) in the world frame."""


def toward(current: np.ndarray, goal: np.ndarray, max_step: np.ndarray) -> np.ndarray:
    """``current`` moved toward ``goal`` by at most ``max_step`` per entry.

    Example:
        >>> toward(np.zeros(2), np.array([1.0, -0.001]), np.full(2, 0.01))
        array([ 0.01 , -0.001])
    """
    return current + np.clip(goal - current, -max_step, max_step)


def _yaw(angle_rad: float) -> np.ndarray:
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class KnifeCommand:
    """The knife tip's target: a point of the planned cut plus offsets in the path's frame.

    The frame at path parameter ``tau_s`` is the planned tip pose there: x along the cutting
    edge (the path's tangent), y across (the blade's normal), z down the blade's axis. ``tau_s``
    is the planned trajectory's time, so that moving along at the plan's own speed replays
    the plan; it stays within the cut window. An action's first entry is the speed along the
    path, from standing (-1) to ``knife_along_speed_m_s`` (1): a knife cuts forward, and a
    policy exploring about zero moves on at half that speed rather than dithering in the
    cut; the other three are the offsets wanted (across, depth, yaw; 1 is the limit's bound),
    which the target's offsets move to at the limits' speeds.

    Args:
        trajectory: the planned knife trajectory (``knife`` of
            :class:`cell.sim.episode.EpisodePlan`).
        window_s: its cutting window, s.
        speed_m_s: the plan's cutting speed.
        limits: speeds and bounds.

    Example:
        >>> from cell.sim.episode import Episode
        >>> from cell.sim.scenario import Scenario
        >>> from cell.tissue.shape import MuscleShape
        >>> episode = Episode(Scenario(tissue=MuscleShape(cell_size_m=0.05)))
        >>> plan = episode.plan()
        >>> command = KnifeCommand(plan.knife, plan.cut_window_s, 0.03, ActionLimits())
        >>> (position_m, rotation), bounded = command.advance(np.array([-0.2, 0, 0.5, 0]), 0.02)
        >>> command.progress > 0.0, bounded, command.depth_m  # 10 mm wanted, at 20 mm/s
        (True, 0, 0.0004)
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
        """Move for ``dt_s`` by ``action`` = (along speed, across, depth, yaw wanted) in
        [-1, 1]; returns the new target and whether the cut window held the progress back
        (0 or 1)."""
        lim = self.limits
        speed_m_s = 0.5 * (action[0] + 1.0) * lim.knife_along_speed_m_s
        wanted_tau = self.tau_s + speed_m_s / self.speed_m_s * dt_s
        self.tau_s = float(np.clip(wanted_tau, *self.window_s))
        bound = np.array([lim.knife_max_across_m, lim.knife_max_depth_m, lim.knife_max_yaw_rad])
        rate = np.array([lim.knife_across_speed_m_s, lim.knife_depth_speed_m_s,
                         lim.knife_yaw_rate_rad_s])
        offsets = toward(self.offsets(), np.asarray(action[1:], float) * bound, rate * dt_s)
        self.across_m, self.depth_m, self.yaw_rad = map(float, offsets)
        return self.target(), int(self.tau_s != wanted_tau)

    def follow(self, t_s: float) -> None:
        """Put the path's parameter where the scripted knife is at ``t_s`` (within the window),
        so that a policy of the pull sees the knife's progress."""
        self.tau_s = float(np.clip(t_s, *self.window_s))

    def offsets(self) -> np.ndarray:
        """(across m, depth m, yaw rad) now."""
        return np.array([self.across_m, self.depth_m, self.yaw_rad])


class PullCommand:
    """The grasp site's target: the grasp point plus a displacement, within
    ``pull_max_distance_m`` of it and at most ``pull_max_sink_m`` below. An action is the
    displacement wanted (world axes), each entry cubed times ``pull_max_distance_m``, which
    the displacement moves to at ``pull_speed_m_s`` along each axis: cubed, because holding
    the shank still while the knife cuts matters to a few mm (the bindings tear at 8-12 mm of
    stretch) and taking it away to centimetres, so the millimetres near the grasp point get
    most of the action's range (an action of 0.3 is 5.4 mm).

    Example:
        >>> command = PullCommand(np.zeros(3), np.eye(3), ActionLimits())
        >>> (position_m, rotation), bounded = command.advance(np.array([0.0, 1.0, -1.0]), 0.02)
        >>> position_m, bounded  # 0.2 m below is beyond the sink's bound
        (array([ 0.   ,  0.001, -0.001]), 1)
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
        """Move for ``dt_s`` toward the displacement ``action`` (3,) in [-1, 1] wants; returns
        the new target and whether the bounds held the wanted place back (0 or 1)."""
        lim = self.limits
        wanted = np.asarray(action, float) ** 3 * lim.pull_max_distance_m
        bounded = wanted.copy()
        bounded[2] = max(bounded[2], -lim.pull_max_sink_m)
        distance = float(np.linalg.norm(bounded))
        if distance > lim.pull_max_distance_m:
            bounded *= lim.pull_max_distance_m / distance
        self.displacement_m = toward(self.displacement_m, bounded, lim.pull_speed_m_s * dt_s)
        return self.target(), int(not np.array_equal(bounded, wanted))
