"""The cutting model on the cell's seam: where the knife's edge meets uncut aponeurosis, and
the forces of its edge and faces there.

The cell's knife cuts along the aponeurosis between the two muscles, its edge upright in the
seam, from the interface's top line down to the knife's tip. :class:`SeamCut` finds from the
geometry alone (the interface's top line, the table, the blade's pose) how much of the edge
cuts uncut seam and how much of the blade lies in the meat, and gives the forces of
:mod:`cell.tissue.cutmodel` on them: the edge's (:func:`~cell.tissue.cutmodel.edge_force`)
and the faces' friction (:func:`~cell.tissue.cutmodel.face_friction_force`), from the blade's
velocity split into push and slice (:func:`~cell.tissue.cutmodel.push_and_slice`). The mesh
plays no part, so the forces are the same at any cell size.

What is cut is kept as a profile along the top line: the lowest height the edge has swept at
each place (bins of :data:`PROFILE_BIN_M`). The edge meets uncut seam between that height
and its tip, so a second, deeper pass cuts only what the first left, and an edge drawn back
through its own cut cuts nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cell.tissue.cutmodel import (
    CuttingParams,
    edge_force,
    face_friction_force,
    push_and_slice,
)

#: Length of a bin of the cut profile along the seam, m: finer than any tissue cell and than
#: the reach of the knife's edge in one control step.
PROFILE_BIN_M = 0.001
#: Push speed (m/s) at which the edge force reaches 76 % of its full value (tanh(1)): a
#: crack front resists like friction, against the edge's advance and fading when the knife
#: stands, so it takes energy out and never pushes back a knife that has stopped (a force
#: that switched on and off at zero speed would chatter in the servo's step). The cut runs at
#: several times this speed.
STALL_SPEED_M_S = 0.005
#: Points along the engaged edge at which the depth factor (layers, indentation) is averaged.
DEPTH_SAMPLES = 16


@dataclass(frozen=True)
class SeamLoad:
    """The cutting model's load on the blade at one instant (world frame).

    Attributes:
        edge_n: the edge's force, N (fracture of the seam; zero unless the edge advances).
        faces_n: the faces' friction, N.
        moment_nm: the moment of both about the blade's centre, N m.
        resistance_n: the force to push the edge through the uncut seam here at the
            reference speed, without slicing, N: ``G L`` weighted by the depth factor (the
            force release rule's cutting force).
        engaged_m: length of edge in uncut seam, m.
        face_area_m2: area of one face of the blade inside the meat, m^2.

    Example:
        >>> load = SeamLoad(np.zeros(3), np.zeros(3), np.zeros(3), 0.0, 0.0, 0.0)
        >>> load.on_blade_n.tolist()
        [0.0, 0.0, 0.0]
    """

    edge_n: np.ndarray
    faces_n: np.ndarray
    moment_nm: np.ndarray
    resistance_n: float
    engaged_m: float
    face_area_m2: float

    @property
    def on_blade_n(self) -> np.ndarray:
        """The edge's force and the faces' friction together, N."""
        return self.edge_n + self.faces_n


#: Where along the engaged edge the depth samples lie, as shares of its length from the bottom.
_DEPTH_FRACTIONS = (np.arange(DEPTH_SAMPLES) + 0.5) / DEPTH_SAMPLES

_NO_LOAD = SeamLoad(np.zeros(3), np.zeros(3), np.zeros(3), 0.0, 0.0, 0.0)


class SeamCut:
    """The cutting model's forces on a blade cutting along a seam, and the cut so far.

    Args:
        params: the cutting model (its toughness that of the seam).
        top_line_m: (K, 3) the interface's top line, world frame, ordered along x: the seam's
            top at each x (between its points, linearly; outside them the meat ends).
        bottom_z_m: the seam's bottom, world z (the table), m.
        gradient: the toughness graded along the top line: the edge's force and resistance
            times ``exp(gradient (x - x_mid) / L)`` at the blade's centre ``x``, ``x_mid`` the
            line's middle and ``L`` its length (0: the same all along).

    The blade is a box (``half_size_m``: x width, y thickness, z length) whose cutting edge
    is its +x face, upright in the seam; its z axis points to the tip.

    Example:
        >>> top = np.array([[-0.2, 0.0, 0.08], [0.2, 0.0, 0.08]])
        >>> seam = SeamCut(CuttingParams(toughness_j_m2=200.0), top, 0.0)
        >>> down = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
        >>> half = np.array([0.0125, 0.0005, 0.1])
        >>> load = seam.load(np.array([0.0, 0.0, 0.105]), down, half, np.array([0.03, 0, 0]))
        >>> round(load.engaged_m, 3), (load.edge_n.round(2) + 0.0).tolist()  # 200 x 0.075
        (0.075, [-15.0, 0.0, 0.0])
        >>> seam.load(np.array([-0.001, 0.0, 0.105]), down, half, np.array([-0.03, 0, 0])
        ...           ).engaged_m  # drawn back through its own cut
        0.0
    """

    def __init__(self, params: CuttingParams, top_line_m: np.ndarray, bottom_z_m: float,
                 gradient: float = 0.0) -> None:
        self.params = params
        self._uniform = params.uniform()  # the depth factor is applied along the edge here
        top = np.asarray(top_line_m, dtype=float)
        start, end = float(top[0, 0]), float(top[-1, 0])
        count = max(1, math.ceil((end - start) / PROFILE_BIN_M))
        self._edges = np.linspace(start, end, count + 1)
        self._width = (end - start) / count
        self._top = np.interp(0.5 * (self._edges[1:] + self._edges[:-1]), top[:, 0], top[:, 2])
        self._bottom = float(bottom_z_m)
        self._gradient = float(gradient)
        self._mid, self._length = 0.5 * (start + end), max(abs(end - start), 1e-6)
        self.reset()

    def reset(self) -> None:
        """Nothing cut yet."""
        self._floor = self._top.copy()
        self._last_x: float | None = None

    def _bin(self, x_m: float) -> int | None:
        index = math.floor((x_m - self._edges[0]) / self._width) if self._width > 0 else 0
        return index if 0 <= index < len(self._top) else None

    def load(self, blade_pos: np.ndarray, blade_mat: np.ndarray, half_size_m: np.ndarray,
             velocity_m_s: np.ndarray) -> SeamLoad:
        """The load on the blade at this pose and velocity (m/s, world, the blade centre's),
        the cut profile then swept by the edge's move since the last call."""
        rot = np.asarray(blade_mat, dtype=float).reshape(3, 3)
        edge, normal, axis = rot[:, 0], rot[:, 1], rot[:, 2]
        centre = np.asarray(blade_pos, dtype=float)
        x = float(centre[0] + half_size_m[0] * edge[0])
        rise = abs(float(axis[2]))
        reach = float(half_size_m[2]) * rise
        high, low = float(centre[2]) + reach, float(centre[2]) - reach  # the edge's ends, m
        at_edge, at_centre = self._bin(x), self._bin(float(centre[0]))
        self._sweep(x, max(low, self._bottom), edge[0])
        if rise < 1e-6 or (at_edge is None and at_centre is None):
            return _NO_LOAD
        bottom = max(low, self._bottom)
        uncut = 0.0 if at_edge is None else max(0.0, min(float(self._floor[at_edge]), high)
                                                 - bottom)
        inside = 0.0 if at_centre is None else max(0.0, min(float(self._top[at_centre]), high)
                                                   - bottom)
        if uncut == 0.0 and inside == 0.0:
            return _NO_LOAD
        engaged = uncut / rise
        push, slide = push_and_slice(velocity_m_s, axis, normal)
        forward = float(push @ edge)
        resistance = 0.0
        edge_n = np.zeros(3)
        grade = (1.0 if not self._gradient else
                 math.exp(self._gradient * (float(centre[0]) - self._mid) / self._length))
        if uncut > 0.0:
            heights = bottom + _DEPTH_FRACTIONS * uncut
            weighted = engaged * float(self.params.depth_factor(self._top[at_edge] - heights)
                                       .mean())
            resistance = self.params.toughness_j_m2 * weighted * grade
            if forward > 0.0:
                edge_n = edge_force(self._uniform, weighted, push, slide, 0.0) * math.tanh(
                    forward / STALL_SPEED_M_S) * grade
        area = inside / rise * 2.0 * half_size_m[0]
        faces_n = face_friction_force(self.params, area, push, slide) if area > 0 else np.zeros(3)
        # The edge's force acts at the middle of its engaged part, the faces' at the middle of
        # the blade's part in the meat; t runs along the blade's axis from its centre.
        t_edge = (bottom + 0.5 * uncut - centre[2]) / axis[2]
        t_faces = (bottom + 0.5 * inside - centre[2]) / axis[2]
        moment = (_cross(half_size_m[0] * edge + t_edge * axis, edge_n)
                  + _cross(t_faces * axis, faces_n))
        return SeamLoad(edge_n, faces_n, moment, resistance, engaged, area)

    def _sweep(self, x_m: float, tip_z_m: float, heading: float) -> None:
        """Lower the cut profile to the edge's tip over the bins whose far end the edge
        passed, moving forward (along ``heading``, the edge's x), since the last call."""
        last, self._last_x = self._last_x, x_m
        if last is None or heading == 0.0 or (x_m - last) * heading <= 0.0:
            return
        far = self._edges[1:] if heading > 0 else self._edges[:-1]
        # The bins whose far end lies in (last, x], found in the sorted ends.
        first, end = np.searchsorted(far, (min(last, x_m), max(last, x_m)), side="right")
        passed = self._floor[first:end]
        np.minimum(passed, tip_z_m, out=passed)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` of two 3-vectors: np.cross's axis handling costs more than the arithmetic,
    and this runs before every physics step while the knife is in the meat."""
    a0, a1, a2 = float(a[0]), float(a[1]), float(a[2])
    b0, b1, b2 = float(b[0]), float(b[1]), float(b[2])
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])
