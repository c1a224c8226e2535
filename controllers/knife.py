"""The knife controller's plan: follow a cut path at a set depth and speed, blade along it."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from cell.config import require_non_negative, require_positive
from cell.errors import InputError
from cell.polyline import truncate
from controllers.trajectory import CartesianTrajectory, Waypoint

#: Speed of free moves between poses (m/s) and of vertical approach moves.
TRANSIT_SPEED_M_S = 0.25
APPROACH_SPEED_M_S = 0.06


@dataclass(frozen=True)
class CutPlan:
    """Where and how the knife cuts: along the interface's top line at ``depth_m`` below it
    (tip), never closer than ``table_clearance_m`` to the table, at ``speed_m_s``, entering
    ``lead_in_m`` before the meat's end and leaving ``lead_out_m`` after ``cut_fraction`` of
    the line (1 = the whole interface). ``enabled = false`` keeps the knife waiting above the
    entry point.

    Example:
        >>> CutPlan(cut_fraction=0.5).depth_m
        0.065
        >>> CutPlan(cut_fraction=1.5)
        Traceback (most recent call last):
        cell.errors.InputError: cut_fraction: must be <= 1, got 1.5
    """

    enabled: bool = True
    speed_m_s: float = 0.03
    depth_m: float = 0.065
    table_clearance_m: float = 0.015
    approach_height_m: float = 0.06
    lead_in_m: float = 0.04
    lead_out_m: float = 0.04
    cut_fraction: float = 1.0
    start_s: float = 0.4

    def __post_init__(self) -> None:
        require_positive(self, "speed_m_s", "depth_m", "approach_height_m", "cut_fraction",
                  "table_clearance_m")
        require_non_negative(self, "lead_in_m", "lead_out_m", "start_s")
        if self.cut_fraction > 1:
            raise InputError(None, "cut_fraction", f"must be <= 1, got {self.cut_fraction}")


#: A surface y(x, z) in world coordinates (m), such as the interface between the muscles.
SurfaceY = Callable[[np.ndarray, np.ndarray], np.ndarray]


class CutWindow(NamedTuple):
    """When the knife cuts, s: from leaving the entry at depth (``start_s``) to reaching the
    cut path's last point (``end_s``).

    Example:
        >>> start_s, end_s = window = CutWindow(3.0, 19.5)
        >>> window.end_s - window.start_s
        16.5
    """

    start_s: float
    end_s: float


def blade_rotation(tangent: np.ndarray, down: np.ndarray = (0.0, 0.0, -1.0)) -> np.ndarray:
    """Tool rotation with the tool axis (z) along ``down`` and the cutting edge (x) along
    ``tangent`` made orthogonal to it, so that the blade plane contains both."""
    z = np.asarray(down, float) / np.linalg.norm(down)
    x = np.asarray(tangent, float) - np.dot(tangent, z) * z
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


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
             start_pos: np.ndarray, start_rot: np.ndarray,
             interface_y: SurfaceY | None = None,
             ) -> tuple[CartesianTrajectory, np.ndarray, CutWindow]:
    """Knife tip trajectory for one cut along ``path_m`` (K, 3), the top line of the interface.

    The tip goes above the entry point (``lead_in_m`` before the path's start), down to
    ``depth_m`` below the path (but ``table_clearance_m`` above ``table_z_m``), along it at
    ``speed_m_s``, ``lead_out_m`` past its end when the whole path is cut, then up. Given the
    interface surface ``interface_y``, the tip follows it at depth and the blade leans with
    it, so that the blade slides along the aponeurosis instead of pushing into the muscles.

    Returns:
        The trajectory, the planned tip path while cutting (N, 3) m, and the cutting window.
    """
    path = truncate(np.asarray(path_m, float), plan.cut_fraction)
    tangents = _tangents(path)
    above_entry, _ = ready_pose(path, plan)
    cut = [above_entry - [0.0, 0.0, plan.approach_height_m], *path]
    if plan.cut_fraction >= 1.0:
        cut.append(path[-1] + plan.lead_out_m * tangents[-1])
    top = np.array(cut)
    cut = top.copy()
    cut[:, 2] = np.maximum(cut[:, 2] - plan.depth_m, table_z_m + plan.table_clearance_m)
    if interface_y is not None:
        cut[:, 1] = interface_y(cut[:, 0], cut[:, 2])
        top[:, 1] = interface_y(top[:, 0], top[:, 2])
    entry = cut[0]
    cut_tangents = [tangents[0], *tangents]
    if plan.cut_fraction >= 1.0:
        cut_tangents.append(tangents[-1])
    cut_rotations = [blade_rotation(t, c - p) for t, c, p in zip(cut_tangents, cut, top,
                                                                    strict=True)]
    above_entry = entry + (plan.depth_m + plan.approach_height_m) * -cut_rotations[0][:, 2]
    approach = [
        Waypoint(above_entry, cut_rotations[0], TRANSIT_SPEED_M_S, dwell_s=0.2),
        Waypoint(entry, cut_rotations[0], APPROACH_SPEED_M_S, dwell_s=0.2),
    ]
    along = [Waypoint(p, r, plan.speed_m_s) for p, r in zip(cut[1:], cut_rotations[1:],
                                                             strict=True)]
    exit_up = cut[-1] - (plan.depth_m + plan.approach_height_m) * cut_rotations[-1][:, 2]
    trajectory = CartesianTrajectory(start_s, start_pos, start_rot, [
        *approach, *along, Waypoint(exit_up, cut_rotations[-1], APPROACH_SPEED_M_S)])
    entry_index, last_cut_index = len(approach) - 1, len(approach) + len(along) - 1
    window = CutWindow(float(trajectory.departures_s[entry_index]),
                       float(trajectory.arrivals_s[last_cut_index]))
    return trajectory, cut, window
