"""Steering the blade by what it feels: the interface's lean below the guideline, corrected
from the knife's lateral load while it cuts.

The camera's top view does not show how the interface leans (the knife tip's error at depth
is the depth times the lean's error), but the flesh does: it pushes the blade back towards
the interface. The pulled muscle's side gives less than the other, and mid-cut, under the
pull, hardly anything. The steering low-passes that load and integrates what lies beyond a
dead band around the load it holds (a little above the on-interface one, so that a blade on
the side that feels little drifts back) into a change of the lean, a load towards the pulled
side counting ``pulled_side_gain`` times: the target at depth ``d`` below the guideline moves
across the cut by ``-lean_change * d``. The load across can read as the pulled side's where
the blade runs in the other muscle, and the pulled side's weight then drives the tip deeper,
to the lean's bound; but that muscle lifts the blade, much more than the interface or the
pulled side do, so above ``in_flesh_lift_n`` of lift the correction moves the tip towards the
pulled side only. It learns only where the load tells the lean: the tip deeper than
``min_depth_m`` and in the middle of the cut, away from the meat's ends (where the load on a
blade on the interface swings from one side at the entry to the other at the exit).

The settings were chosen on tuning shapes, steep and nearly upright interfaces, for the tip's
distance to the interface and the torn fraction (docs/benchmarks.md gives the loads measured
and the effect). The pulled side's weight also rectifies a noisy load: where the tissue tears
in jerks the lean drifts to its bound.

Example (the load pushing the blade 2 N towards +y, as when the tip runs on the -y side):
    >>> guideline = np.array([[-0.2, 0.0, 0.66], [0.2, 0.0, 0.66]])
    >>> steering = LeanSteering(SteeringParams(), guideline, pulled_side=np.array([0, 1, 0]))
    >>> target = (np.array([0.0, 0.0, 0.60]), np.eye(3))  # 6 cm deep, mid-cut
    >>> for _ in range(50):
    ...     position_m, _ = steering.correct(target, np.array([0.0, 2.0, 0.0]), 0.02)
    >>> bool(position_m[1] > 0.0), round(steering.lean_change, 4)  # steered towards +y
    (True, -0.0063)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell.config import require_flag, require_non_negative, require_positive
from cell.errors import InputError

Pose = tuple[np.ndarray, np.ndarray]


@dataclass(frozen=True)
class SteeringParams:
    """How the knife's lateral load corrects the interface's lean (module docstring).

    Attributes:
        enabled: steer by the load; false keeps the planned lean.
        gain_per_n_s: lean change per second per newton of load beyond the dead band.
        on_interface_load_n: the load across the cut the steering holds, N: a little more
            than a blade on the interface feels mid-cut on the default shape, so that a blade
            on the pulled muscle's side, which barely feels more there, drifts back to where
            the other side pushes.
        dead_band_n: loads within this of it change nothing, N.
        filter_s: time constant of the load's low-pass filter, s.
        min_depth_m: the tip's least depth below the guideline for the load to count, m.
        middle_fraction: the part of the guideline's length, about its middle, where the
            load counts.
        max_lean_change: the largest change of the lean (``|dy/dz|``) either way.
        pulled_side_gain: a load beyond the dead band away from the pulled side (the tip on
            that side) counts this many times: that side pushes back about a fifth as hard
            per millimetre.
        in_flesh_lift_n: an upward load on the blade above this (filtered, N) says the tip
            runs in the muscle that is not pulled, whatever the load across says: the
            correction then moves it towards the pulled side only, by what the lift exceeds
            this: the lift of a tip in that muscle is several times that of a tip on the
            interface or on the pulled side, and there a load across the wrong way had turned
            the pulled side's weight against the interface and run the lean to its bound.

    Example:
        >>> SteeringParams(gain_per_n_s=0.02).dead_band_n
        0.1
    """

    enabled: bool = True
    gain_per_n_s: float = 0.01
    on_interface_load_n: float = 1.0
    dead_band_n: float = 0.1
    filter_s: float = 0.3
    min_depth_m: float = 0.01
    middle_fraction: float = 0.75
    max_lean_change: float = 0.12
    pulled_side_gain: float = 4.0
    in_flesh_lift_n: float = 1.0

    def __post_init__(self) -> None:
        require_flag(self, "enabled")
        require_positive(self, "filter_s", "middle_fraction", "in_flesh_lift_n")
        require_non_negative(self, "gain_per_n_s", "dead_band_n", "min_depth_m",
                             "max_lean_change", "pulled_side_gain")
        if self.middle_fraction > 1.0:
            raise InputError(None, "middle_fraction", f"must be <= 1, got "
                             f"{self.middle_fraction}")


class LeanSteering:
    """The lean correction of one cut along ``guideline_m`` (K, 3), world, m.

    Across the cut is the horizontal normal of the guideline's chord that points to the pulled
    muscle (``pulled_side``, the gripper's pull direction, world): loads and the lean's change
    count positive that way, whichever end the cut starts from (the default cell: world +y,
    the lean of ``y = ... + lean * z``).

    Attributes:
        lean_change: the correction so far (dy/dz, dimensionless).
        load_n: the filtered load across the cut, N.
        lift_n: the filtered upward load on the blade, N.
        extremes: the least and the greatest lean change so far.
    """

    def __init__(self, params: SteeringParams, guideline_m: np.ndarray,
                 pulled_side: np.ndarray) -> None:
        points = np.asarray(guideline_m, dtype=float)
        self.params = params
        chord = points[-1, :2] - points[0, :2]
        along = chord / np.linalg.norm(chord)
        self._along = np.array([along[0], along[1], 0.0])
        across = np.array([-along[1], along[0], 0.0])
        self._across = across if across @ np.asarray(pulled_side, float) >= 0.0 else -across
        station = (points - points[0]) @ self._along
        order = np.argsort(station)
        self._station, self._top_z = station[order], points[order, 2]
        self._origin = points[0]
        self._middle = 0.5 * (self._station[0] + self._station[-1])
        self._half_window = 0.5 * params.middle_fraction * (self._station[-1] - self._station[0])
        self.lean_change = 0.0
        self.load_n = params.on_interface_load_n  # neutral until the blade feels otherwise
        self.lift_n = 0.0
        self.extremes = (0.0, 0.0)

    def correct(self, target: Pose, load_n: np.ndarray, dt_s: float) -> Pose:
        """The knife's planned ``target`` (position m, rotation) moved across the cut by the
        lean correction at its depth, after learning from ``load_n`` (3,), the load on the
        blade in the world frame (N), over the control step ``dt_s`` (s)."""
        position, rotation = target
        params = self.params
        if not params.enabled:
            return target
        station = float((position - self._origin) @ self._along)
        depth = max(float(np.interp(station, self._station, self._top_z)) - position[2], 0.0)
        blend = min(dt_s / params.filter_s, 1.0)
        self.load_n += (float(load_n @ self._across) - self.load_n) * blend
        self.lift_n += (float(load_n[2]) - self.lift_n) * blend
        if depth > params.min_depth_m and abs(station - self._middle) <= self._half_window:
            beyond = self.load_n - params.on_interface_load_n
            beyond = np.sign(beyond) * max(abs(beyond) - params.dead_band_n, 0.0)
            if self.lift_n > params.in_flesh_lift_n:  # in the muscle that is not pulled
                beyond = max(beyond, self.lift_n - params.in_flesh_lift_n)
            elif beyond < 0.0:  # the tip on the pulled muscle's side, which pushes back less
                beyond *= params.pulled_side_gain
            self.lean_change = float(np.clip(
                self.lean_change - params.gain_per_n_s * beyond * dt_s,
                -params.max_lean_change, params.max_lean_change))
            self.extremes = (min(self.extremes[0], self.lean_change),
                             max(self.extremes[1], self.lean_change))
        return position - self.lean_change * depth * self._across, rotation
