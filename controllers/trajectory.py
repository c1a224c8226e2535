"""Timed Cartesian trajectories: straight segments between waypoints at set speeds."""

from __future__ import annotations

from bisect import bisect_left, bisect_right
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from cell.errors import ControlError


@dataclass(frozen=True)
class Waypoint:
    """A pose to reach, at ``speed_m_s`` along the straight segment leading to it.

    ``dwell_s`` holds the pose after arrival. Position in m (world), rotation as a 3x3 matrix.

    Example:
        >>> import numpy as np
        >>> Waypoint(np.array([0.0, 0.0, 0.7]), np.eye(3), speed_m_s=0.05, dwell_s=0.2).dwell_s
        0.2
    """

    position_m: np.ndarray
    rotation: np.ndarray
    speed_m_s: float
    dwell_s: float = 0.0


class CartesianTrajectory:
    """Piecewise-linear positions and slerped rotations through waypoints, timed by speed.

    Rotation-only segments take ``min_segment_s`` or the time set by ``max_turn_rad_s``.

    Attributes:
        times_s: (M,) the knots' times, s: the start, then each waypoint's arrival and, where
            it dwells, its departure.
        positions_m: (M, 3) the positions at the knots, m.
        arrivals_s: (K,) when each of the K waypoints is reached, s.
        departures_s: (K,) when each waypoint is left, its dwell after its arrival, s.

    Example:
        >>> import numpy as np
        >>> traj = CartesianTrajectory(start_s=0.0, start_pos=np.zeros(3), start_rot=np.eye(3),
        ...                            waypoints=[Waypoint(np.array([0.1, 0.0, 0.0]), np.eye(3),
        ...                                                speed_m_s=0.05, dwell_s=0.5)])
        >>> traj.arrivals_s, traj.departures_s, traj.end_s
        (array([2.]), array([2.5]), 2.5)
        >>> position_m, rotation = traj.sample(1.0)
        >>> position_m
        array([0.05, 0.  , 0.  ])
    """

    def __init__(self, start_s: float, start_pos: np.ndarray, start_rot: np.ndarray,
                 waypoints: Sequence[Waypoint], max_turn_rad_s: float = 1.0,
                 min_segment_s: float = 0.05) -> None:
        times = [start_s]
        positions = [np.asarray(start_pos, float)]
        rotations = [np.asarray(start_rot, float)]
        arrivals, departures = [], []
        for wp in waypoints:
            if not wp.speed_m_s > 0:
                raise ControlError(f"waypoint speed must be > 0, got {wp.speed_m_s}")
            distance = float(np.linalg.norm(wp.position_m - positions[-1]))
            turn = (Rotation.from_matrix(rotations[-1]).inv()
                    * Rotation.from_matrix(wp.rotation)).magnitude()
            duration = max(distance / wp.speed_m_s, turn / max_turn_rad_s, min_segment_s)
            times.append(times[-1] + duration)
            positions.append(np.asarray(wp.position_m, float))
            rotations.append(np.asarray(wp.rotation, float))
            arrivals.append(times[-1])
            if wp.dwell_s > 0:
                times.append(times[-1] + wp.dwell_s)
                positions.append(positions[-1])
                rotations.append(rotations[-1])
            departures.append(times[-1])
        self.times_s = np.array(times)
        self.arrivals_s = np.array(arrivals)
        self.departures_s = np.array(departures)
        self.positions_m = np.array(positions)
        # Sampled at every control step, where scipy's Slerp objects are dear: the knots'
        # quaternions and each segment's rotation vector are kept for _slerp_matrix.
        knots = Rotation.from_matrix(np.array(rotations))
        self._quats = knots[:-1].as_quat(scalar_first=True)
        self._turns = (knots[:-1].inv() * knots[1:]).as_rotvec()
        self._times = self.times_s.tolist()

    @property
    def end_s(self) -> float:
        """Time at which the last waypoint is reached, s."""
        return float(self.times_s[-1])

    def sample(self, time_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Position (3,) m and rotation (3, 3) at ``time_s`` (held before start, after end)."""
        times = self._times
        t = min(max(float(time_s), times[0]), times[-1])
        # np.interp's arithmetic, so that positions stay bit for bit what it gave.
        j = bisect_right(times, t) - 1
        if j == len(times) - 1 or times[j] == t:
            position = self.positions_m[j].copy()
        else:
            start, end = self.positions_m[j], self.positions_m[j + 1]
            position = (end - start) / (times[j + 1] - times[j]) * (t - times[j]) + start
        # Slerp's segment: the one ending at t when t is a knot, the first at the start.
        i = max(bisect_left(times, t) - 1, 0)
        alpha = (t - times[i]) / (times[i + 1] - times[i])
        return position, _slerp_matrix(self._quats[i], self._turns[i] * alpha)



def _slerp_matrix(start_wxyz: np.ndarray, turn: np.ndarray) -> np.ndarray:
    """The rotation matrix of quaternion ``start_wxyz`` turned by the rotation vector ``turn``
    (in its own frame), by MuJoCo's quaternion functions: a slerp step without the per-call
    cost of scipy's Rotation objects."""
    quat = start_wxyz.copy()
    mujoco.mju_quatIntegrate(quat, turn, 1.0)
    matrix = np.empty(9)
    mujoco.mju_quat2Mat(matrix, quat)
    return matrix.reshape(3, 3)
