"""The flesh's resistance to the knife's edge while it cuts, and its reaction on the tissue.

A mass-spring mesh of centimetre cells cannot separate under a blade: fracture at the edge and
friction along the faces are put in as forces on the blade, and their reaction on the tissue
vertices nearest the edge, so that the fixture and the table bear it as they would. They come
from the material's cutting model (:class:`~cell.tissue.seamcut.SeamCut`, the scenario's
``aponeurosis.knife_force = "cutting"``, whose reaction :meth:`EdgeResistance.load` spreads)
or from a share of a measured cutting-force curve (:meth:`EdgeResistance.apply`,
``knife_force = "curve"``: :class:`~cell.tissue.forcecurve.ForceCurve`).
"""

from __future__ import annotations

import mujoco
import numpy as np
from numba import njit

from cell.tissue.seamcut import STALL_SPEED_M_S

#: Tissue vertices that share the reaction: the flesh within a few cells of the edge. Fewer
#: push the vertices next to the edge ahead of the blade and stretch the bindings there, and
#: tear about twice as many of them on the default episode; this many tear about as many as
#: without the resistance.
REACTION_VERTICES = 96


class EdgeResistance:
    """A resistance ``force_n`` (N) against the blade's edge, applied on the blade, with its
    reaction spread over the :data:`REACTION_VERTICES` free tissue vertices nearest the edge
    (``data.xfrc_applied`` of their bodies: external loads, as a fixture's dynamometer reads
    them).

    The blade is a box (``half_size_m``: x width, y thickness, z length) whose cutting edge is
    its +x face; the force on the blade is ``-force_n * tanh(v / STALL_SPEED_M_S)`` along x,
    ``v`` the edge's speed along x, applied on the edge next to the loaded vertices.

    Example:
        >>> import mujoco, numpy as np
        >>> from cell.sim.assembly import build_scene
        >>> from cell.sim.scenario import Scenario
        >>> from cell.tissue.geometry import MuscleShape
        >>> scene = build_scene(Scenario(tissue=MuscleShape(cell_size_m=0.05)), robots=False)
        >>> data = mujoco.MjData(scene.model)
        >>> mujoco.mj_forward(scene.model, data)
        >>> edge = EdgeResistance(scene.model)
        >>> centre = data.flexvert_xpos.mean(axis=0)
        >>> half = np.array([0.0125, 0.0005, 0.1])
        >>> force, moment = edge.apply(data, 10.0, centre, np.eye(3), half, np.array([0.03, 0, 0]))
        >>> force.round(2).tolist()  # against the edge advancing along +x at 0.03 m/s
        [-10.0, 0.0, 0.0]
        >>> bool(np.allclose(data.xfrc_applied[:, :3].sum(axis=0), -force))  # the reaction
        True
    """

    def __init__(self, model: mujoco.MjModel) -> None:
        bodies = model.flex_vertbodyid
        # Pinned vertices (no dofs) belong to the fixture, which the cut never reaches.
        self._vertices = np.flatnonzero(model.body_dofnum[bodies] == 3)
        self._bodies = bodies[self._vertices]
        self.reset()

    def reset(self) -> None:
        """Forget the reaction put on the tissue, as a new state starts without it."""
        self._loaded = np.zeros(0, dtype=int)
        self._load = np.zeros(3)

    def apply(self, data: mujoco.MjData, force_n: float, blade_pos: np.ndarray,
              blade_mat: np.ndarray, half_size_m: np.ndarray, blade_velocity: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
        """Put the resistance's reaction on the tissue (taking back the last step's) and return
        the force on the blade (N, world) and its moment about the blade centre (N m).

        ``blade_velocity`` is the blade centre's linear velocity, m/s (world frame).
        """
        # Added to, not written over: other external loads on the vertices stay.
        _add_rows(data.xfrc_applied, self._loaded, -self._load)
        self._loaded = np.zeros(0, dtype=int)
        if force_n == 0.0:  # no resistance whatever the speed; the common case, made cheap
            return np.zeros(3), np.zeros(3)
        rot = np.asarray(blade_mat, float).reshape(3, 3)
        edge, axis = rot[:, 0], rot[:, 2]
        magnitude = force_n * np.tanh(float(blade_velocity @ edge) / STALL_SPEED_M_S)
        if magnitude == 0.0 or len(self._vertices) == 0:
            return np.zeros(3), np.zeros(3)
        on_blade = -magnitude * edge
        along = self._spread(data, on_blade, blade_pos + half_size_m[0] * edge, axis,
                             half_size_m[2])
        # Applied on the edge (x) at the loaded vertices' mean height along the blade (z):
        # z cross x is the blade's y.
        return on_blade, -magnitude * along * rot[:, 1]

    def load(self, data: mujoco.MjData, on_blade_n: np.ndarray, blade_pos: np.ndarray,
             blade_mat: np.ndarray, half_size_m: np.ndarray) -> None:
        """Put the reaction of ``on_blade_n`` (N, world: a load the caller puts on the blade's
        edge and faces, such as :class:`~cell.tissue.seamcut.SeamCut`'s) on the tissue,
        taking back the last step's."""
        _add_rows(data.xfrc_applied, self._loaded, -self._load)
        self._loaded = np.zeros(0, dtype=int)
        if not on_blade_n.any() or len(self._vertices) == 0:
            return
        rot = np.asarray(blade_mat, float).reshape(3, 3)
        self._spread(data, on_blade_n, blade_pos + half_size_m[0] * rot[:, 0], rot[:, 2],
                     half_size_m[2])

    def _spread(self, data: mujoco.MjData, on_blade: np.ndarray, edge_centre: np.ndarray,
                axis: np.ndarray, half_length: float) -> float:
        """Spread ``-on_blade`` over the vertices nearest the edge; returns their mean place
        along the blade's axis from the edge's centre, m."""
        distance, along = _from_edge(data.flexvert_xpos, self._vertices, edge_centre, axis,
                                     half_length)
        count = min(REACTION_VERTICES, len(self._vertices))
        near = np.argpartition(distance, count - 1)[:count]
        self._loaded, self._load = self._bodies[near], -on_blade / count
        _add_rows(data.xfrc_applied, self._loaded, self._load)
        # sum / count is ndarray.mean's arithmetic, without its overhead.
        return float(along[near].sum() / count)


@njit(cache=True)
def _from_edge(xpos: np.ndarray, vertices: np.ndarray, edge_centre: np.ndarray,
               axis: np.ndarray, half_length: float) -> tuple[np.ndarray, np.ndarray]:
    """Distance (m) of each vertex from the edge segment (``edge_centre`` +- ``half_length``
    along ``axis``) and where along it its nearest point lies. Compiled: it runs before every
    physics step while the knife cuts."""
    distance = np.empty(len(vertices))
    along = np.empty(len(vertices))
    for i in range(len(vertices)):
        t = 0.0
        for k in range(3):
            t += (xpos[vertices[i], k] - edge_centre[k]) * axis[k]
        t = min(max(t, -half_length), half_length)
        squared = 0.0
        for k in range(3):
            squared += (xpos[vertices[i], k] - edge_centre[k] - t * axis[k]) ** 2
        distance[i] = np.sqrt(squared)
        along[i] = t
    return distance, along


@njit(cache=True)
def _add_rows(target: np.ndarray, rows: np.ndarray, value: np.ndarray) -> None:
    """``target[rows, :3] += value`` for distinct ``rows``, without numpy's fancy indexing
    (whose overhead per call counts: it runs before every physics step)."""
    for row in rows:
        for k in range(3):
            target[row, k] += value[k]
