"""The knife controller's plan: follow a cut path at a set depth and speed, blade along it."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from cell.config import require_count, require_non_negative, require_positive
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
    the line (1 = the whole interface). ``depth_m`` None (the default) cuts down to the
    clearance everywhere, however tall the meat: the interface's lowest bindings lie on the
    table, and a fixed depth leaves them to tear under meat taller than it. ``passes`` > 1
    cuts in that many passes, pass i of n to i / n of the depth (the paper's small incisions),
    the knife waiting ``look_dwell_s`` out of the cut between them while the camera looks
    again (:func:`plan_passes`). ``enabled = false`` keeps the knife waiting above the entry
    point.

    Example:
        >>> CutPlan(cut_fraction=0.5).depth_m is None  # down to the table's clearance
        True
        >>> CutPlan(cut_fraction=1.5)
        Traceback (most recent call last):
        cell.errors.InputError: cut_fraction: must be <= 1, got 1.5
    """

    enabled: bool = True
    speed_m_s: float = 0.03
    depth_m: float | None = None
    table_clearance_m: float = 0.0025
    approach_height_m: float = 0.06
    lead_in_m: float = 0.04
    lead_out_m: float = 0.04
    cut_fraction: float = 1.0
    start_s: float = 0.4
    passes: int = 1
    look_dwell_s: float = 0.3

    def __post_init__(self) -> None:
        require_positive(self, "speed_m_s", "approach_height_m", "cut_fraction",
                         "table_clearance_m")
        if self.depth_m is not None:
            require_positive(self, "depth_m")
        require_non_negative(self, "lead_in_m", "lead_out_m", "start_s", "look_dwell_s")
        require_count(self, "passes", 1)
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


#: The estimate's slope at the seen path's ends is taken over this length inward, m.
_SLOPE_BASE_M = 0.03


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


def _continued(interface_y: SurfaceY, x_m: np.ndarray, z_m: np.ndarray,
               seen_x_m: tuple[float, float]) -> np.ndarray:
    """The estimate's y (m) at (``x_m``, ``z_m``), continued along its slope in x past the
    seen path's x-range ``seen_x_m``: the estimate holds along the seen path only, and the
    lead-in and lead-out run past the meat's ends, where its bow term would bend the blade's
    path away within centimetres and across the end face."""
    low, high = seen_x_m
    seen = np.clip(x_m, low, high)
    inward = np.where(seen > 0.5 * (low + high), -_SLOPE_BASE_M, _SLOPE_BASE_M)
    y = interface_y(seen, z_m)
    slope = (interface_y(seen + inward, z_m) - y) / inward
    return y + slope * (np.asarray(x_m) - seen)


def _pass_waypoints(path: np.ndarray, plan: CutPlan, fraction: float, table_z_m: float,
                    interface_y: SurfaceY | None, dwell_out_s: float
                    ) -> tuple[list[Waypoint], np.ndarray, int, int]:
    """One pass along ``path`` (K, 3) with the tip ``fraction`` of the plan's depth below it:
    the waypoints from above the entry to out of the cut (the last one dwells
    ``dwell_out_s``), the tip path while cutting (N, 3) m, and the index of the entry at depth
    and of the last cut point."""
    tangents = _tangents(path)
    above_entry, _ = ready_pose(path, plan)
    cut = [above_entry - [0.0, 0.0, plan.approach_height_m], *path]
    if plan.cut_fraction >= 1.0:
        cut.append(path[-1] + plan.lead_out_m * tangents[-1])
    top = np.array(cut)
    cut = top.copy()
    floor_z = table_z_m + plan.table_clearance_m
    depth = top[:, 2] - floor_z if plan.depth_m is None else plan.depth_m
    cut[:, 2] = np.maximum(top[:, 2] - fraction * depth, floor_z)
    if interface_y is not None:
        seen_x = (path[:, 0].min(), path[:, 0].max())
        cut[:, 1] = _continued(interface_y, cut[:, 0], cut[:, 2], seen_x)
        top[:, 1] = _continued(interface_y, top[:, 0], top[:, 2], seen_x)
    entry = cut[0]
    cut_tangents = [tangents[0], *tangents]
    if plan.cut_fraction >= 1.0:
        cut_tangents.append(tangents[-1])
    cut_rotations = [blade_rotation(t, c - p) for t, c, p in zip(cut_tangents, cut, top,
                                                                    strict=True)]
    depth_m = top[:, 2] - cut[:, 2]
    above_entry = entry + (depth_m[0] + plan.approach_height_m) * -cut_rotations[0][:, 2]
    approach = [
        Waypoint(above_entry, cut_rotations[0], TRANSIT_SPEED_M_S, dwell_s=0.2),
        Waypoint(entry, cut_rotations[0], APPROACH_SPEED_M_S, dwell_s=0.2),
    ]
    along = [Waypoint(p, r, plan.speed_m_s) for p, r in zip(cut[1:], cut_rotations[1:],
                                                             strict=True)]
    exit_up = cut[-1] - (depth_m[-1] + plan.approach_height_m) * cut_rotations[-1][:, 2]
    out = Waypoint(exit_up, cut_rotations[-1], APPROACH_SPEED_M_S, dwell_s=dwell_out_s)
    return [*approach, *along, out], cut, len(approach) - 1, len(approach) + len(along) - 1


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
    passes = plan_passes(path_m, plan, table_z_m, start_s, start_pos, start_rot, interface_y,
                         count=1)
    return passes.trajectory, passes.cut_paths_m[-1], passes.windows_s[0]


@dataclass(frozen=True, eq=False)
class PassPlan:
    """The knife's cut in passes, each deeper than the last, the knife out of the meat between
    them while the camera looks again.

    Attributes:
        trajectory: the tip's trajectory through every pass (world frame, m; s).
        cut_paths_m: per pass, the planned tip path while cutting (N, 3), m.
        depths_m: per pass, the tip's greatest depth below the guideline, m.
        windows_s: per pass, when it cuts (from the entry at depth to the last cut point), s.
        looks_s: when the knife has left pass k's cut and waits for the camera (one time
            between each two passes), s.

    Example:
        >>> path = np.array([[-0.2, 0.0, 0.65], [0.0, 0.0, 0.66], [0.2, 0.0, 0.65]])
        >>> passes = plan_passes(path, CutPlan(passes=2), 0.6, 0.0, path[0] + [0, 0, 0.1],
        ...                      np.eye(3))
        >>> [round(d, 4) for d in passes.depths_m], len(passes.looks_s)  # to 0.6025 m at last
        ([0.0287, 0.0575], 1)
        >>> passes.windows_s[0].end_s < passes.looks_s[0] < passes.windows_s[1].start_s
        True
    """

    trajectory: CartesianTrajectory
    cut_paths_m: tuple[np.ndarray, ...]
    depths_m: tuple[float, ...]
    windows_s: tuple[CutWindow, ...]
    looks_s: tuple[float, ...]

    @property
    def window_s(self) -> CutWindow:
        """From the first pass's entry at depth to the last pass's last cut point, s."""
        return CutWindow(self.windows_s[0].start_s, self.windows_s[-1].end_s)

    def pass_at(self, time_s: float) -> int | None:
        """The pass cutting at ``time_s``, None between passes and outside the cut."""
        for index, (start, end) in enumerate(self.windows_s):
            if start <= time_s <= end:
                return index
        return None


def plan_passes(path_m: np.ndarray, plan: CutPlan, table_z_m: float, start_s: float,
                start_pos: np.ndarray, start_rot: np.ndarray,
                interface_y: SurfaceY | None = None, count: int | None = None) -> PassPlan:
    """The cut along ``path_m`` (K, 3) in ``count`` passes (by default ``plan.passes``), pass
    i of n to i / n of the plan's depth, each as :func:`plan_cut` describes one; between
    passes the knife waits ``look_dwell_s`` out of the cut, then goes back above the entry."""
    count = plan.passes if count is None else count
    path = truncate(np.asarray(path_m, float), plan.cut_fraction)
    waypoints: list[Waypoint] = []
    paths, depths, marks = [], [], []
    for index in range(count):
        dwell = plan.look_dwell_s if index < count - 1 else 0.0
        points, cut, entry, last = _pass_waypoints(path, plan, (index + 1) / count, table_z_m,
                                                   interface_y, dwell)
        done = len(waypoints)
        marks.append((done + entry, done + last, done + len(points) - 1))
        waypoints += points
        paths.append(cut)
        depths.append(float(np.max(path[:, 2] - cut[1:len(path) + 1, 2])))
    trajectory = CartesianTrajectory(start_s, start_pos, start_rot, waypoints)
    windows = tuple(CutWindow(float(trajectory.departures_s[entry]),
                              float(trajectory.arrivals_s[last])) for entry, last, _ in marks)
    looks = tuple(float(trajectory.departures_s[out]) for _, _, out in marks[:-1])
    return PassPlan(trajectory, tuple(paths), tuple(depths), windows, looks)
