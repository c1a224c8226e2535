"""Cartesian trajectories: sampling is np.interp (bit for bit) and scipy's Slerp (to
rounding)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from controllers.trajectory import CartesianTrajectory, Waypoint


@pytest.mark.parametrize("turn_rad", [1e-4, 3.0])  # scipy's small-angle series, and beyond
def test_sample_equals_interp_and_slerp(turn_rad: float) -> None:
    rng = np.random.default_rng(7)
    start = Rotation.random(random_state=rng)
    rotations = [start.as_matrix()]
    waypoints = []
    for _ in range(4):
        rotations.append((Rotation.from_rotvec(rng.normal(size=3) * turn_rad)
                          * Rotation.from_matrix(rotations[-1])).as_matrix())
        waypoints.append(Waypoint(rng.normal(size=3) * 0.2, rotations[-1], 0.1, dwell_s=0.2))
    traj = CartesianTrajectory(0.5, np.zeros(3), rotations[0], waypoints)
    knots = [rotations[0]] + [r for r in rotations[1:] for _ in range(2)]  # each dwells
    slerp = Slerp(traj.times_s, Rotation.from_matrix(np.array(knots)))
    times = np.concatenate([traj.times_s, rng.uniform(0.0, traj.end_s + 1.0, 200)])
    for t in times:
        clipped = float(np.clip(t, traj.times_s[0], traj.end_s))
        position, rotation = traj.sample(t)
        expected = [np.interp(clipped, traj.times_s, traj.positions_m[:, k]) for k in range(3)]
        assert np.array_equal(position, expected)
        np.testing.assert_allclose(rotation, slerp([clipped]).as_matrix()[0], atol=1e-12)
