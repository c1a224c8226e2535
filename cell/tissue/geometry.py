"""The round and the shank of a :class:`~cell.tissue.shape.MuscleShape` meshed into well-shaped
tets, with their facing vertex pairs and the top edge of the interface.

Frame: the shape's (:mod:`cell.tissue.shape`), moved so that ``origin_m`` is the middle of the
interface at table level. Each muscle is a mapped structured grid (u, v, w) in [0, 1]^3:
x = (u - 1/2) L; v runs from the interface (offset by half the gap) to the vertical outer wall;
z = w h(x, d) up to the curved top, where d = v * plan width is the distance from the interface
at table level. The shape is fitted exactly, with no staircase. Both muscles share the (u, w)
sampling of the interface, so facing vertices pair up one to one, the same z, the gap apart
along y. Hexes split into tets with the mirrored Kuhn split.

Example:
    >>> mesh = build_two_muscles(MuscleShape(cell_size_m=0.05))
    >>> len(mesh.round.points) + len(mesh.shank.points), len(mesh.pairs)
    (240, 30)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell.tissue.shape import Muscle, MuscleShape
from cell.tissue.tetmesh import TetMesh, dihedral_angles_deg, structured_hex_tets


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
    side, width, _ = shape.side_of(muscle)
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
