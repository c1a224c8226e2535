"""How well a cut follows the aponeurosis, measured against the truth the simulation knows.

The true interface is the bound surface of the two muscles: the midpoints of the aponeurosis
bindings' vertex pairs where they are now (the round's interface triangles with each corner
moved to its pair's midpoint), so it deforms and opens with the meat. While the knife cuts,
:class:`CutScore` measures each control step

- the knife tip's distance to that surface (m), kept per pass, and
- the flesh the blade sweeps: points along the blade's edge, from the tip up to the
  interface's top edge, lie in flesh where they are farther from the mid-surface than the
  muscle's face (half the local distance between the pair's vertices, plus half the blade's
  thickness); the edge's length in flesh times the tip's advance is area swept (m^2), times
  the blade's thickness the blade volume swept inside a muscle (m^3).

Only steps whose tip lies across from the interface count: within its extent along x and
off it along its normal, not past its edge (the lead-in and lead-out are outside the meat,
and the tip entering the end face is past the deformed surface's edge for a moment).

Example:
    >>> from cell.sim.assembly import build_scene
    >>> from cell.sim.scenario import Scenario
    >>> from cell.tissue.geometry import MuscleShape
    >>> scene = build_scene(Scenario(tissue=MuscleShape(cell_size_m=0.05)), robots=False)
    >>> data = mujoco.MjData(scene.model)
    >>> mujoco.mj_forward(scene.model, data)
    >>> score = CutScore(scene.aponeurosis, scene.mesh, blade_length_m=0.1,
    ...                  blade_thickness_m=0.001)
    >>> middle = scene.mesh.top_line[len(scene.mesh.top_line) // 2] - [0.0, 0.0, 0.03]
    >>> score.observe(data, 0, middle + [0.0, 0.01, 0.0], np.array([0.0, 0.0, -1.0]))
    >>> round(score.tip_distance()["mean"], 4)  # 1 cm off the interface, into the shank
    0.01
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from cell.perception.registration import closest_on_triangles
from cell.profiling import timed
from cell.tissue.aponeurosis import Aponeurosis
from cell.tissue.geometry import TwoMuscleMesh

#: Points sampled along the blade's edge each step.
_EDGE_SAMPLES = 16
#: A point lies across from the interface (not past its edge, as the tip entering the meat's
#: end face does) where its offset from the closest point is this close to the normal.
_ACROSS_COSINE = 0.95


def interface_triangles(mesh: TwoMuscleMesh) -> np.ndarray:
    """(T, 3) the interface as triangles over binding indices: the round's boundary
    triangles whose three corners are all bound, each corner named by its binding."""
    binding_of = np.full(len(mesh.round.points), -1)
    binding_of[mesh.pairs[:, 0]] = np.arange(len(mesh.pairs))
    corners = binding_of[mesh.round.boundary]
    return corners[(corners >= 0).all(axis=1)]


class CutScore:
    """The knife tip's distance to the true interface and the flesh the blade sweeps.

    Args:
        aponeurosis: the scene's bindings (their vertices give the interface where it is now).
        mesh: the muscles' meshes, for the interface's triangles and cell size.
        blade_length_m: how far up from the tip the edge is sampled, m.
        blade_thickness_m: the blade's thickness, m.

    The module's example shows one step.
    """

    def __init__(self, aponeurosis: Aponeurosis, mesh: TwoMuscleMesh, blade_length_m: float,
                 blade_thickness_m: float) -> None:
        self.aponeurosis = aponeurosis
        self.triangles = interface_triangles(mesh)
        self.blade_length_m = blade_length_m
        self.blade_half_thickness_m = blade_thickness_m / 2.0
        # Bindings within this distance along x of a point tell the interface's top there.
        self._station_m = mesh.shape.cell_size_m
        self._tip_distance: list[tuple[int, float]] = []
        self._worst: dict[str, float] = {}
        self._flesh_area_m2 = 0.0
        self._last_tip: np.ndarray | None = None

    def _distances(self, points: np.ndarray, midpoints: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Distance (m) of each of ``points`` (N, 3) to the interface surface, the binding
        nearest its closest point, and whether the point lies across from the surface (its
        offset along the closest triangle's normal) rather than past its edge."""
        corners = midpoints[self.triangles]
        candidates = np.broadcast_to(np.arange(len(corners)), (len(points), len(corners)))
        closest, triangle = closest_on_triangles(points, corners, candidates)
        nearest_corner = np.argmin(np.linalg.norm(
            corners[triangle] - closest[:, None, :], axis=2), axis=1)
        binding = self.triangles[triangle, nearest_corner]
        offset = points - closest
        distance = np.linalg.norm(offset, axis=1)
        a, b, c = (corners[triangle, i] for i in range(3))
        normal = np.cross(b - a, c - a)
        normal /= np.linalg.norm(normal, axis=1, keepdims=True)
        along_normal = np.abs(np.einsum("ij,ij->i", offset, normal))
        across = along_normal >= _ACROSS_COSINE * distance
        return distance, binding, across

    @timed("scoring")
    def observe(self, data: mujoco.MjData, pass_index: int, tip_m: np.ndarray,
                blade_axis: np.ndarray) -> None:
        """Score one control step of cutting: the tip at ``tip_m`` (m), the blade running up
        from it along ``-blade_axis`` (the tool's z, unit, pointing to the tip)."""
        tip = np.asarray(tip_m, dtype=float).copy()
        round_m, shank_m = self.aponeurosis.endpoints(data)
        midpoints = 0.5 * (round_m + shank_m)
        advance = 0.0 if self._last_tip is None else float(np.linalg.norm(tip - self._last_tip))
        self._last_tip = tip
        if not midpoints[:, 0].min() <= tip[0] <= midpoints[:, 0].max():
            return
        near = np.abs(midpoints[:, 0] - tip[0]) <= self._station_m
        top_z = midpoints[near, 2].max() if near.any() else midpoints[:, 2].max()
        # Each sample stands for an equal share of the edge, at its middle.
        heights = (np.arange(_EDGE_SAMPLES) + 0.5) * self.blade_length_m / _EDGE_SAMPLES
        edge = tip - heights[:, None] * np.asarray(blade_axis, dtype=float)
        edge = edge[edge[:, 2] <= top_z]
        points = np.vstack([tip, edge])
        distance, binding, across = self._distances(points, midpoints)
        if not across[0]:
            return
        self._tip_distance.append((pass_index, float(distance[0])))
        if distance[0] >= self._worst.get("distance_m", -1.0):
            self._worst = {"distance_m": float(distance[0]), "time_s": float(data.time),
                           "x_m": float(tip[0]), "z_m": float(tip[2])}
        if len(edge) == 0 or advance == 0.0:
            return
        half_gap = 0.5 * np.linalg.norm(shank_m - round_m, axis=1)[binding[1:]]
        in_flesh = distance[1:] - self.blade_half_thickness_m > half_gap
        segment_m = self.blade_length_m / _EDGE_SAMPLES
        self._flesh_area_m2 += float(in_flesh.sum()) * segment_m * advance

    def lift(self) -> None:
        """The knife left the cut: its next step starts a new sweep."""
        self._last_tip = None

    def tip_distance(self) -> dict[str, Any]:
        """The tip's distance to the interface (m): ``mean``, ``p95`` and ``max`` over the
        whole cut, where the max was (``max_at``: time s, tip x and z m), ``samples``, and
        ``passes``, the same per pass (in pass order)."""
        if not self._tip_distance:
            return {"mean": None, "p95": None, "max": None, "max_at": None, "samples": 0,
                    "passes": []}
        passes, distance = (np.array(column) for column in zip(*self._tip_distance,
                                                               strict=True))
        per_pass = [{"pass": int(p), "mean": float(distance[passes == p].mean()),
                     "max": float(distance[passes == p].max()),
                     "samples": int((passes == p).sum())} for p in np.unique(passes)]
        return {"mean": float(distance.mean()), "p95": float(np.percentile(distance, 95)),
                "max": float(distance.max()), "max_at": self._worst,
                "samples": len(distance), "passes": per_pass}

    def flesh_damage(self) -> dict[str, Any]:
        """The flesh damage: the blade's area and volume swept inside a muscle (m^2, m^3)
        and the bindings the knife missed (released by no knife rule: torn or still
        bound), torn and left bound, with their fractions of all bindings."""
        apo = self.aponeurosis
        counts = apo.released_counts()
        total = len(apo)
        torn = counts.get("tearing", 0)
        left = int(apo.bound.sum())
        cut = total - torn - left
        return {
            "blade_area_in_flesh_m2": self._flesh_area_m2,
            "blade_volume_in_flesh_m3": self._flesh_area_m2 * 2.0 * self.blade_half_thickness_m,
            "bindings_missed": total - cut,
            "bindings_torn": torn,
            "bindings_left": left,
            "missed_fraction": (total - cut) / total,
            "torn_fraction": torn / total,
        }
