"""Two muscles from scanned surfaces: repaired, tetrahedralised, bound where they meet.

The round's and the shank's closed surfaces (:mod:`cell.tissue.surface`: one file each, or one
file holding both as separate bodies, the round the one at lower y) are filled with tets by
TetGen (:mod:`cell.tissue.mesher`). The interface is where the two meet: the vertices of
each muscle's surface within ``interface_tolerance_m`` of the other's surface. Each such
vertex is bound to the nearest interface vertex of the other muscle (both ways, each pair
once), as the procedural muscles' facing vertices are; the rest length of a binding is the
distance between its two vertices. The interface's top edge (the valley the knife enters) runs
through the bindings on the upper border of the round's bound surface patch, the highest
midpoint per ``cell_size_m`` slice along x; a quadratic y(x, z) fitted to all the midpoints
stands for the interface surface the knife follows at depth.

Example:
    >>> shape = MuscleShape(surface_mesh=("assets/meshes/scan/round.ply",
    ...                                   "assets/meshes/scan/shank.ply"), cell_size_m=0.04)
    >>> mesh = build_tissue(shape, origin_m=(0.0, 0.0, 0.6))
    >>> len(mesh.pairs) > 20, round(mesh.interface_area_m2, 2)
    (True, 0.03)
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial import cKDTree

from cell.errors import MeshError, NoInterfaceError
from cell.extras import optional
from cell.tissue.geometry import MuscleShape, TwoMuscleMesh, build_two_muscles, quadratic_terms
from cell.tissue.mesher import tetrahedralise
from cell.tissue.surface import load_surfaces
from cell.tissue.tetmesh import TetMesh

if TYPE_CHECKING:
    import trimesh

_FIELD = "tissue.surface_mesh"
#: Fewer bindings than this is no interface worth cutting (and too few to fit its surface).
MIN_PAIRS = 6


def build_tissue(shape: MuscleShape,
                 origin_m: tuple[float, float, float] | np.ndarray = (0.0, 0.0, 0.0)
                 ) -> TwoMuscleMesh:
    """The scanned muscles of ``shape.surface_mesh`` placed at ``origin_m`` (the table
    point under the interface's middle, m), or the procedural ones when it names none.

    Raises:
        MeshError: a file cannot be read, or holds other than the two bodies.
        NotWatertightError, SelfIntersectionError, TetrahedralisationError: a surface that
            cannot be filled (see :mod:`cell.tissue.surface` and :mod:`cell.tissue.mesher`).
        NoInterfaceError: the two surfaces do not meet within ``interface_tolerance_m``.
    """
    if not shape.surface_mesh:
        return build_two_muscles(shape, origin_m)
    origin = np.array(origin_m, dtype=float).reshape(3)
    sources, surfaces = _surfaces(shape.surface_mesh)
    meshes = [tetrahedralise(surface, source, _FIELD, shape.cell_size_m)
              for surface, source in zip(surfaces, sources, strict=True)]
    pairs = _interface_pairs(meshes, surfaces, shape.interface_tolerance_m, sources)
    round_mesh, shank_mesh = (TetMesh.from_arrays(m.points + origin, m.tets, str(s))
                              for m, s in zip(meshes, sources, strict=True))
    a, b = round_mesh.points[pairs[:, 0]], shank_mesh.points[pairs[:, 1]]
    middle = (a + b) / 2.0 - origin  # TwoMuscleMesh.pair_midpoints_m, before it exists
    fit, *_ = np.linalg.lstsq(quadratic_terms(middle[:, 0], middle[:, 2]).T, middle[:, 1],
                              rcond=None)
    rest = np.linalg.norm(b - a, axis=1)
    top = _top_line(round_mesh, pairs, middle, shape.cell_size_m) + origin
    for array in (origin, pairs, rest, top, fit):
        array.setflags(write=False)
    return TwoMuscleMesh(shape, origin, round_mesh, shank_mesh, pairs, rest, top, fit)


def _surfaces(files: tuple[str, ...]) -> tuple[list[str], list[trimesh.Trimesh]]:
    """The round's and the shank's repaired surfaces, and the file each came from."""
    bodies = [(name, body) for name in files for body in load_surfaces(name, _FIELD)]
    if len(bodies) != 2:
        counts = ", ".join(f"{name}: {sum(n == name for n, _ in bodies)}" for name in files)
        raise MeshError(files[0] if len(files) == 1 else None, _FIELD,
                        f"needs exactly two closed bodies, the round and the shank; found "
                        f"{counts}")
    # One file of both: the round is the body at lower y.
    bodies.sort(key=lambda item: item[1].vertices[:, 1].mean() if len(files) == 1 else 0.0)
    return [name for name, _ in bodies], [body for _, body in bodies]


def _interface_pairs(meshes: list[TetMesh], surfaces: list[trimesh.Trimesh],
                     tolerance_m: float, sources: list[str]) -> np.ndarray:
    """(P, 2) bound vertex pairs (round index, shank index), ordered by x then z."""
    import trimesh  # lazily: the shapes drawn without a scan do not need it

    optional("rtree", "mesh", f"{_FIELD} (the interface search)")
    near = []
    closest = []
    for mesh, other in ((meshes[0], surfaces[1]), (meshes[1], surfaces[0])):
        surface_vertices = np.unique(mesh.boundary)
        _, distance, _ = trimesh.proximity.closest_point(other, mesh.points[surface_vertices])
        near.append(surface_vertices[distance <= tolerance_m])
        closest.append(float(distance.min()))
    if min(len(ids) for ids in near) == 0:
        raise NoInterfaceError(
            " and ".join(dict.fromkeys(sources)), _FIELD,
            f"the muscles do not meet: no surface vertex lies within the "
            f"interface_tolerance_m of {tolerance_m} m of the other muscle (closest "
            f"{min(closest):.4g} m)")
    round_ids, shank_ids = near
    _, to_shank = cKDTree(meshes[1].points[shank_ids]).query(meshes[0].points[round_ids])
    _, to_round = cKDTree(meshes[0].points[round_ids]).query(meshes[1].points[shank_ids])
    pairs = np.unique(np.vstack([np.column_stack([round_ids, shank_ids[to_shank]]),
                                 np.column_stack([round_ids[to_round], shank_ids])]), axis=0)
    if len(pairs) < MIN_PAIRS:
        raise NoInterfaceError(" and ".join(dict.fromkeys(sources)), _FIELD,
                               f"only {len(pairs)} vertex pairs meet within {tolerance_m} m; "
                               f"at least {MIN_PAIRS} make an interface")
    middle = (meshes[0].points[pairs[:, 0]] + meshes[1].points[pairs[:, 1]]) / 2.0
    return pairs[np.lexsort((middle[:, 2], middle[:, 0]))]


def _top_line(round_mesh: TetMesh, pairs: np.ndarray, middle_m: np.ndarray,
              slice_m: float) -> np.ndarray:
    """(K, 3) top edge of the interface along +x: of the bindings on the upper half of the
    border of the round's bound surface patch, the highest midpoint per slice along x."""
    patch = round_mesh.boundary[np.isin(round_mesh.boundary, pairs[:, 0]).all(axis=1)]
    edges = np.sort(patch[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    border = np.unique(unique[counts == 1])
    z = round_mesh.points[border, 2]
    upper = border[z >= z.min() + 0.5 * np.ptp(z)]
    on_top = np.isin(pairs[:, 0], upper)
    candidates = middle_m[on_top] if on_top.any() else middle_m
    x = candidates[:, 0]
    slices = np.rint((x - x.min()) / slice_m).astype(int)
    return np.array([candidates[slices == k][np.argmax(candidates[slices == k, 2])]
                     for k in np.unique(slices)])
