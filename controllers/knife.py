"""The knife controller's plan: follow a cut path at a set depth and speed, blade along it."""

from __future__ import annotations

import numpy as np

from cell.scenario import CutPlan
from controllers.trajectory import CartesianTrajectory, Waypoint

#: Speed of free moves between poses (m/s) and of vertical approach moves.
TRANSIT_SPEED_M_S = 0.25
APPROACH_SPEED_M_S = 0.06


def blade_rotation(tangent: np.ndarray) -> np.ndarray:
    """Tool rotation with the tool axis (z) pointing down and the cutting edge (x) along the
    horizontal projection of ``tangent``, so that the blade plane contains the path."""
    x = np.array([tangent[0], tangent[1], 0.0])
    x /= np.linalg.norm(x)
    z = np.array([0.0, 0.0, -1.0])
    return np.column_stack([x, np.cross(z, x), z])


def truncate_path(path_m: np.ndarray, fraction: float) -> np.ndarray:
    """The first ``fraction`` of a polyline's arc length (m)."""
    steps = np.linalg.norm(np.diff(path_m, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(steps)])
    end = fraction * arc[-1]
    keep = arc < end - 1e-9
    tail = np.array([np.interp(end, arc, path_m[:, k]) for k in range(3)])
    return np.vstack([path_m[keep], tail])


def _tangents(path_m: np.ndarray) -> np.ndarray:
    tangents = np.gradient(path_m, axis=0)
    return tangents / np.linalg.norm(tangents, axis=1, keepdims=True)


def ready_pose(path_m: np.ndarray, plan: CutPlan) -> tuple[np.ndarray, np.ndarray]:
    """Tip pose (m, rotation) above the entry point, where the knife waits before the cut."""
    path = np.asarray(path_m, float)
    tangent = _tangents(path)[0]
    above = path[0] - plan.lead_in_m * tangent + np.array([0.0, 0.0, plan.approach_height_m])
    return above, blade_rotation(tangent)


def plan_cut(path_m: np.ndarray, plan: CutPlan, table_z_m: float, start_s: float,
             start_pos: np.ndarray, start_rot: np.ndarray
             ) -> tuple[CartesianTrajectory, np.ndarray, tuple[float, float]]:
    """Knife tip trajectory for one cut along ``path_m`` (K, 3), the top line of the interface.

    The tip goes above the entry point (``lead_in_m`` before the path's start), down to
    ``depth_m`` below the path (but ``table_clearance_m`` above ``table_z_m``), along it at
    ``speed_m_s``, ``lead_out_m`` past its end when the whole path is cut, then up.

    Returns:
        The trajectory, the planned tip path while cutting (N, 3) m, and the cutting window
        (start, end) in s.
    """
    path = truncate_path(np.asarray(path_m, float), plan.cut_fraction)
    tangents = _tangents(path)
    above_entry, _ = ready_pose(path, plan)
    cut = [above_entry - [0.0, 0.0, plan.approach_height_m], *path]
    if plan.cut_fraction >= 1.0:
        cut.append(path[-1] + plan.lead_out_m * tangents[-1])
    cut = np.array(cut)
    cut[:, 2] = np.maximum(cut[:, 2] - plan.depth_m, table_z_m + plan.table_clearance_m)
    entry = cut[0]
    cut_rotations = [blade_rotation(tangents[0]), *(blade_rotation(t) for t in tangents)]
    if plan.cut_fraction >= 1.0:
        cut_rotations.append(blade_rotation(tangents[-1]))
    waypoints = [
        Waypoint(above_entry, cut_rotations[0], TRANSIT_SPEED_M_S, dwell_s=0.2),
        Waypoint(entry, cut_rotations[0], APPROACH_SPEED_M_S, dwell_s=0.2),
    ]
    waypoints += [Waypoint(p, r, plan.speed_m_s) for p, r in zip(cut[1:], cut_rotations[1:],
                                                                  strict=True)]
    exit_up = np.array([*cut[-1, :2], above_entry[2]])
    waypoints.append(Waypoint(exit_up, cut_rotations[-1], APPROACH_SPEED_M_S))
    trajectory = CartesianTrajectory(start_s, start_pos, start_rot, waypoints)
    cut_start = float(trajectory.times_s[4])
    cut_end = float(trajectory.times_s[-2])
    return trajectory, cut, (cut_start, cut_end)
