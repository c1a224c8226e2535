"""Procedural shape of the round and the shank side by side, meshed into well-shaped tets.

Frame: x along the muscles, z up from the table, the round at y < 0 and the shank at y > 0;
``origin_m`` is the middle of the interface at table level. Each muscle is a mapped structured
grid (u, v, w) in [0, 1]^3: x = (u - 1/2) L; v runs from the interface (offset by half the gap)
to the vertical outer wall; z = w h(x, d) up to the curved top, where d = v * plan width is the
distance from the interface at table level. The shape is fitted exactly, with no staircase. Both
muscles share the (u, w) sampling of the interface, so facing vertices pair up one to one, the
same z, the gap apart along y. Hexes split into tets with the mirrored Kuhn split.

Example:
    >>> mesh = build_two_muscles(MuscleShape(cell_size_m=0.05))
    >>> len(mesh.round.points) + len(mesh.shank.points), len(mesh.pairs)
    (240, 30)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Literal

import numpy as np

from cell.errors import InputError
from cell.tissue.tetmesh import TetMesh, dihedral_angles_deg, structured_hex_tets

# The rounded top edge turns the top down by this much before it meets the vertical outer wall:
# a mapped grid needs a corner there, and 135 degrees keeps the corner cells well shaped (a full
# quarter round makes a flat corner and slivers).
_EDGE_SWEEP_RAD = math.radians(45.0)
# The derived valley width: the default shape's 0.03 m, or 1.15 times the valley's rise where
# that is wider (the walls then stay below 37 degrees, the 45 the mesh allows with margin).
_VALLEY_WIDTH_M = 0.03
_VALLEY_WIDTH_PER_RISE = 1.15

Muscle = Literal["round", "shank"]
"""Which of the two muscles: the round lies at y < 0, the shank at y > 0."""


@dataclass(frozen=True)
class MuscleShape:
    """Dimensions of the two-muscle specimen and its mesh resolution (SI units).

    Attributes:
        length_m: length along x of both muscles.
        round_width_m: width of the round (y < 0), from the interface middle to its outer wall.
        shank_width_m: width of the shank (y > 0), likewise.
        round_height_m: crest height of the round above the table.
        shank_height_m: crest height of the shank above the table.
        interface_bow_m: in plan view the interface bows towards the shank by this much in the
            middle relative to its ends (negative bows towards the round).
        interface_lean: slope dy/dz of the interface (dimensionless, within +-0.5): it leans
            towards the shank as it rises when positive.
        valley_depth_m: how far the top edge of the interface lies below the crest of the lower
            muscle: the valley the cut follows.
        valley_width_m: lateral decay length of the valley on each side; at least 0.86 times
            the rise from the interface top to the higher crest, so no wall passes 45 degrees.
            None (the default) derives it from the shape (:attr:`valley_decay_m`): 0.03 m, or
            1.15 times the rise where that is wider.
        edge_radius_m: radius of the rounded top edge along each outer wall: a circular arc
            that turns the top down by 45 degrees, dropping it 0.29 times this, before the
            vertical wall.
        end_taper: fraction of the height lost at the two ends, in [0, 0.6] (0 keeps it
            constant along x).
        gap_m: distance along y between facing vertices of the two muscles (they never touch).
        cell_size_m: target edge length of the structured grid; the counts are rounded up
            (of a scan's tets: their largest edge, about).
        surface_mesh: closed surface files of a scanned or segmented pair of muscles
            (:mod:`cell.tissue.scan`): two, the round's then the shank's, or one that holds
            both as separate bodies. Given, they replace the procedural shape, whose
            dimensions are then unused.
        interface_tolerance_m: a scan's vertex lies on the interface when it is within this
            distance of the other muscle's surface.

    Raises:
        InputError: a field out of range; ``field`` names it.

    Example:
        >>> MuscleShape(cell_size_m=0.05).cell_counts()
        (9, 3, 3, 2)
    """

    length_m: float = 0.45
    round_width_m: float = 0.13
    shank_width_m: float = 0.11
    round_height_m: float = 0.10
    shank_height_m: float = 0.09
    interface_bow_m: float = 0.02
    interface_lean: float = 0.1
    valley_depth_m: float = 0.015
    valley_width_m: float | None = None
    edge_radius_m: float = 0.05
    end_taper: float = 0.25
    gap_m: float = 0.003
    cell_size_m: float = 0.025
    surface_mesh: tuple[str, ...] = ()
    interface_tolerance_m: float = 0.005

    def __post_init__(self) -> None:
        if len(self.surface_mesh) > 2 or not all(isinstance(name, str)
                                                 for name in self.surface_mesh):
            raise InputError(None, "surface_mesh",
                             f"must be one or two file names, got {self.surface_mesh!r}")
        for f in fields(self):
            if f.name == "surface_mesh" or (f.name == "valley_width_m"
                                            and self.valley_width_m is None):
                continue
            value = getattr(self, f.name)
            if not isinstance(value, int | float) or isinstance(value, bool):
                raise InputError(None, f.name, f"must be a number, got {value!r}")
            if not math.isfinite(value):
                raise InputError(None, f.name, f"must be finite, got {value}")
        for name in (
            "length_m",
            "round_width_m",
            "shank_width_m",
            "round_height_m",
            "shank_height_m",
            "valley_decay_m",
            "edge_radius_m",
            "gap_m",
            "cell_size_m",
            "interface_tolerance_m",
        ):
            if getattr(self, name) <= 0.0:
                key = "valley_width_m" if name == "valley_decay_m" else name
                raise InputError(None, key, f"must be > 0, got {getattr(self, name)}")
        lower = min(self.round_height_m, self.shank_height_m)
        edge_drop = self.edge_radius_m * (1.0 - math.cos(_EDGE_SWEEP_RAD))
        if not 0.0 <= self.valley_depth_m < lower - edge_drop:
            raise InputError(
                None,
                "valley_depth_m",
                f"must be in [0, {lower - edge_drop:.4g}) (the lower height less the drop of "
                f"the rounded edge), got {self.valley_depth_m}",
            )
        # Steeper valley walls than 45 degrees shear the mapped cells into slivers; the
        # steepest slope of the valley profile is rise * sqrt(2 / e) / valley_width_m.
        rise = max(self.round_height_m, self.shank_height_m) - self.interface_top_m
        narrowest_valley = rise * math.sqrt(2.0 / math.e)
        if self.valley_decay_m < narrowest_valley:
            raise InputError(
                None,
                "valley_width_m",
                f"must be >= {narrowest_valley:.4g} so that no valley wall is steeper than "
                f"45 degrees (it rises {rise:.4g} m), got {self.valley_width_m}",
            )
        if not 0.0 <= self.end_taper <= 0.6:
            raise InputError(None, "end_taper", f"must be in [0, 0.6], got {self.end_taper}")
        if abs(self.interface_lean) > 0.5:
            raise InputError(
                None, "interface_lean", f"must be within [-0.5, 0.5], got {self.interface_lean}"
            )
        # The narrowest plan width, where bow and lean both eat into a muscle, must still hold
        # the rounded edge beside the interface.
        edge_run = self.edge_radius_m * math.sin(_EDGE_SWEEP_RAD)
        for name in ("round_width_m", "shank_width_m"):
            narrowest = (
                getattr(self, name)
                - abs(self.interface_bow_m)
                - abs(self.interface_lean) * max(self.round_height_m, self.shank_height_m)
                - self.gap_m / 2.0
            )
            if narrowest <= edge_run:
                raise InputError(
                    None,
                    name,
                    f"leaves {narrowest:.4g} m where bow and lean narrow it, not more than "
                    f"the {edge_run:.4g} m the rounded edge takes",
                )

    def cell_counts(self) -> tuple[int, int, int, int]:
        """Cells along x, across the round, across the shank and up (shared by both).

        Example:
            >>> MuscleShape().cell_counts()
            (18, 6, 5, 4)
        """

        def count(extent_m: float) -> int:
            # A hair of slack keeps exact multiples (0.45 / 0.025) from rounding up a cell.
            return max(1, math.ceil(extent_m / self.cell_size_m - 1e-9))

        return (
            count(self.length_m),
            count(self.round_width_m - self.gap_m / 2.0),
            count(self.shank_width_m - self.gap_m / 2.0),
            count(max(self.round_height_m, self.shank_height_m)),
        )

    @property
    def valley_decay_m(self) -> float:
        """The valley's lateral decay length in use, m: ``valley_width_m`` where given, else
        derived from the rise from the interface top to the higher crest.

        Example:
            >>> MuscleShape().valley_decay_m  # a rise of 0.025 m
            0.03
            >>> round(MuscleShape(round_height_m=0.13).valley_decay_m, 4)  # 0.055 m
            0.0633
        """
        if self.valley_width_m is not None:
            return self.valley_width_m
        rise = max(self.round_height_m, self.shank_height_m) - self.interface_top_m
        return max(_VALLEY_WIDTH_M, _VALLEY_WIDTH_PER_RISE * rise)

    @property
    def interface_top_m(self) -> float:
        """Height of the interface's top edge above the table in the middle, in m."""
        return min(self.round_height_m, self.shank_height_m) - self.valley_depth_m

    def interface_y_m(self, x_m: np.ndarray, z_m: np.ndarray) -> np.ndarray:
        """y of the interface mid-surface at (x, z), in the local frame (origin at its middle).

        Example:
            >>> float(MuscleShape().interface_y_m(np.array(0.0), np.array(0.0)))
            0.0
        """
        s = 2.0 * np.asarray(x_m) / self.length_m
        return -self.interface_bow_m * s**2 + self.interface_lean * np.asarray(z_m)

    def _side_of(self, muscle: Muscle) -> tuple[int, float, float]:
        """Direction in y (-1 round, +1 shank), width (m) and crest height (m) of ``muscle``."""
        if muscle == "round":
            return -1, self.round_width_m, self.round_height_m
        if muscle == "shank":
            return 1, self.shank_width_m, self.shank_height_m
        raise InputError(None, "muscle", f"must be 'round' or 'shank', got {muscle!r}")

    def plan_width_m(self, muscle: Muscle, x_m: np.ndarray) -> np.ndarray:
        """Width of ``muscle`` at table level at x (local frame), interface face to outer wall.

        Example:
            >>> round(float(MuscleShape().plan_width_m("shank", np.array(0.225))), 4)
            0.1285
        """
        side, width, _ = self._side_of(muscle)
        return width - side * self.interface_y_m(x_m, 0.0) - self.gap_m / 2.0

    def top_z_m(self, muscle: Muscle, x_m: np.ndarray, d_m: np.ndarray) -> np.ndarray:
        """Height of the top surface of ``muscle`` at x and lateral coordinate d, in m.

        d in [0, plan_width_m] is the distance from the muscle's interface face at table level;
        the top point it names lies the same fraction d / plan_width_m of the way from the
        interface face to the outer wall at its own height (they differ where the interface
        leans). The top dips to ``interface_top_m`` at d = 0 (the valley) and rounds off with
        ``edge_radius_m`` at the outer wall.

        Example:
            >>> shape = MuscleShape()
            >>> float(shape.top_z_m("round", np.array(0.0), np.array(0.0))) == shape.interface_top_m
            True
        """
        _, _, height = self._side_of(muscle)
        x_m = np.asarray(x_m)
        d_m = np.asarray(d_m)
        low = self.interface_top_m
        # Both muscles end at exactly ``low`` at d = 0, so facing vertices get the same z.
        profile = low + (height - low) * -np.expm1(-((d_m / self.valley_decay_m) ** 2))
        radius = self.edge_radius_m
        run = radius * math.sin(_EDGE_SWEEP_RAD)
        t = np.clip(d_m - (self.plan_width_m(muscle, x_m) - run), 0.0, run)
        profile = profile - (radius - np.sqrt(radius**2 - t**2))
        return profile * (1.0 - self.end_taper * (2.0 * x_m / self.length_m) ** 2)


@dataclass(frozen=True, eq=False)
class TwoMuscleMesh:
    """The two muscle meshes, their facing vertex pairs and the top edge of the interface.

    Arrays are read-only and in metres in the world frame.

    Attributes:
        shape: the shape it was built from.
        origin_m: (3,) world position of the middle of the interface at table level.
        round: tet mesh of the round (y < 0 side).
        shank: tet mesh of the shank (y > 0 side).
        pairs: (P, 2) int facing vertex pairs across the interface, (round index, shank index),
            ordered by x then z.
        pair_rest_lengths_m: (P,) distance between the two vertices of each pair (the gap).
        top_line: (K, 3) midpoints of the top facing pairs, ordered along +x: the top edge of
            the interface, at the bottom of the valley.
        interface_fit: for a scan, the (6,) coefficients of the interface mid-surface
            y = c . (1, x, z, x^2, x z, z^2) in the local frame (m) fitted to the pairs'
            midpoints; None for the procedural shape, whose interface is exact.

    Example:
        >>> mesh = build_two_muscles(MuscleShape(), origin_m=(0.6, 0.0, 0.8))
        >>> bool(np.allclose(mesh.interface_y(mesh.top_line[:, 0], mesh.top_line[:, 2]),
        ...                  mesh.top_line[:, 1]))
        True
    """

    shape: MuscleShape
    origin_m: np.ndarray
    round: TetMesh
    shank: TetMesh
    pairs: np.ndarray
    pair_rest_lengths_m: np.ndarray
    top_line: np.ndarray
    interface_fit: np.ndarray | None = None

    def interface_y(self, x_m: np.ndarray, z_m: np.ndarray) -> np.ndarray:
        """World y of the true interface mid-surface at world (x, z), in m (broadcasts).

        The round's interface face lies ``gap_m / 2`` below it along y, the shank's above
        (a scan's: the fitted mid-surface of its bindings).
        """
        ox, oy, oz = self.origin_m
        x, z = np.asarray(x_m) - ox, np.asarray(z_m) - oz
        if self.interface_fit is None:
            return oy + self.shape.interface_y_m(x, z)
        return oy + np.tensordot(self.interface_fit, quadratic_terms(x, z), axes=1)

    @property
    def pair_midpoints_m(self) -> np.ndarray:
        """(P, 3) world midpoints of the facing pairs, m: points of the interface surface."""
        return 0.5 * (self.round.points[self.pairs[:, 0]] + self.shank.points[self.pairs[:, 1]])

    @property
    def node_count(self) -> int:
        """Vertices of both muscles."""
        return len(self.round.points) + len(self.shank.points)

    @property
    def min_dihedral_deg(self) -> float:
        """Smallest interior dihedral angle of any tet of either muscle, degrees (70.5 for a
        regular tet; slivers near 0 stiffen and slow the solver)."""
        return float(min(dihedral_angles_deg(m.points, m.tets).min()
                         for m in (self.round, self.shank)))

    @property
    def interface_area_m2(self) -> float:
        """Area of the bound interface, m^2: the mean over both muscles of the surface
        triangles whose three vertices are all bound.

        Example:
            >>> round(build_two_muscles(MuscleShape()).interface_area_m2, 4)
            0.0312
        """
        areas = []
        for mesh, bound in ((self.round, self.pairs[:, 0]), (self.shank, self.pairs[:, 1])):
            on = np.isin(mesh.boundary, bound).all(axis=1)
            corners = mesh.points[mesh.boundary[on]]
            cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
            areas.append(0.5 * np.linalg.norm(cross, axis=1).sum())
        return float(np.mean(areas))


def quadratic_terms(x_m: np.ndarray, z_m: np.ndarray) -> np.ndarray:
    """(6, ...) terms (1, x, z, x^2, x z, z^2) of the interface fit, broadcast over x and z."""
    x, z = np.broadcast_arrays(np.asarray(x_m, dtype=float), np.asarray(z_m, dtype=float))
    return np.stack([np.ones_like(x), x, z, x * x, x * z, z * z])


def _muscle_grid(shape: MuscleShape, muscle: Muscle, cells_v: int) -> np.ndarray:
    """(nu + 1, nv + 1, nw + 1, 3) grid points of one muscle in the local frame."""
    side, width, _ = shape._side_of(muscle)
    n_u, _, _, n_w = shape.cell_counts()
    x = ((np.linspace(0.0, 1.0, n_u + 1) - 0.5) * shape.length_m)[:, None, None]
    v = np.linspace(0.0, 1.0, cells_v + 1)[None, :, None]
    w = np.linspace(0.0, 1.0, n_w + 1)[None, None, :]
    z = w * shape.top_z_m(muscle, x, v * shape.plan_width_m(muscle, x))
    inner = shape.interface_y_m(x, z) + side * shape.gap_m / 2.0
    y = (1.0 - v) * inner + v * (side * width)
    return np.stack(np.broadcast_arrays(x, y, z), axis=-1)


def build_two_muscles(
    shape: MuscleShape, origin_m: tuple[float, float, float] | np.ndarray = (0.0, 0.0, 0.0)
) -> TwoMuscleMesh:
    """Mesh the round and the shank of ``shape`` and pair their facing interface vertices.

    Args:
        shape: dimensions and resolution.
        origin_m: world position (m) of the middle of the interface at table level.

    Returns:
        The two validated tet meshes, the facing pairs and the interface's top line.

    Raises:
        MeshError: the generated mesh is invalid (a shape the validation let through folds).

    Example:
        >>> mesh = build_two_muscles(MuscleShape(), origin_m=(0.6, 0.0, 0.8))
        >>> len(mesh.round.points), len(mesh.shank.points), len(mesh.round.tets)
        (665, 570, 2592)
    """
    origin = np.array(origin_m, dtype=float).reshape(3)
    n_u, n_round, n_shank, n_w = shape.cell_counts()
    meshes = []
    interface_ids = []
    muscles: tuple[tuple[Muscle, int], ...] = (("round", n_round), ("shank", n_shank))
    for name, n_v in muscles:
        grid = _muscle_grid(shape, name, n_v)
        tets = structured_hex_tets((n_u, n_v, n_w))
        if name == "round":
            # v runs towards -y, so (u, v, w) -> (x, y, z) is left-handed.
            tets = tets[:, [0, 2, 1, 3]]
        meshes.append(TetMesh.from_arrays(grid.reshape(-1, 3) + origin, tets, name))
        ids = np.arange(grid[..., 0].size).reshape(grid.shape[:3])
        interface_ids.append(ids[:, 0, :].ravel())
    round_mesh, shank_mesh = meshes
    pairs = np.stack(interface_ids, axis=1)
    a = round_mesh.points[pairs[:, 0]]
    b = shank_mesh.points[pairs[:, 1]]
    rest = np.linalg.norm(b - a, axis=1)
    top = ((a + b) / 2.0).reshape(n_u + 1, n_w + 1, 3)[:, -1]
    for array in (origin, pairs, rest, top):
        array.setflags(write=False)
    return TwoMuscleMesh(shape, origin, round_mesh, shank_mesh, pairs, rest, top)
