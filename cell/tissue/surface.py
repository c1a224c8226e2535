"""Closed surfaces of scanned or segmented muscles: read, repaired and checked with trimesh.

A scan (a laser or structured-light scan, or a surface segmented from MRI as the paper's
geometry was) comes in metres in the meat's frame: x along the muscles, z up from the table at
z = 0, the round at y < 0 and the shank at y > 0, the interface's middle near the origin.
Repair merges duplicate vertices, drops degenerate and repeated faces, fills the small holes a
scan leaves, makes the winding consistent and outward, and lays the base flat on the table
(vertices within :data:`BASE_TOLERANCE_M` of z = 0 go to z = 0: the scanner sees the table
there, not the meat). A surface whose triangles cross is refused before any mesher sees it
(TetGen aborts the process on some such surfaces): an edge of one triangle that passes
through another triangle, found by trimesh's ray queries (with ``rtree``, ``mesh`` extra).

Example:
    >>> import trimesh
    >>> surface = trimesh.creation.box((0.1, 0.1, 0.1))
    >>> surface.apply_translation((0.0, 0.0, 0.05))  # doctest: +ELLIPSIS
    <trimesh.Trimesh...>
    >>> repaired_surface(surface, "box.ply", "tissue.surface_mesh").is_volume
    True
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from cell.errors import MeshError, NotWatertightError, SelfIntersectionError
from cell.extras import optional
from cell.io import read_bytes

if TYPE_CHECKING:
    import trimesh

#: Vertices this close to the table plane (m) are laid on it.
BASE_TOLERANCE_M = 0.002


def load_surfaces(path: str | Path, field: str) -> list[trimesh.Trimesh]:
    """The closed bodies of the surface file ``path`` (PLY, STL, OBJ, ... as trimesh reads
    them), each repaired (module docstring); ``field`` names the key that gave the file.

    Raises:
        MeshError: the file cannot be read (:func:`cell.io.read_bytes`: missing, a folder,
            too large) or holds no triangles.
        NotWatertightError: a body still has open edges after repair.
    """
    import trimesh  # only here: an episode that reads no mesh file starts without it

    content = read_bytes(path, "mesh", MeshError)
    try:
        loaded = trimesh.load(io.BytesIO(content), file_type=Path(path).suffix.lstrip("."),
                              force="mesh", process=False)
    except (OSError, ValueError, KeyError, IndexError) as exc:
        raise MeshError(path, field, f"cannot read the surface: {exc}") from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise MeshError(path, field, "holds no triangles")
    whole = repaired_surface(loaded, path, field, check=False)
    bodies = whole.split(only_watertight=False)
    return [repaired_surface(body, path, field) for body in bodies]


def repaired_surface(surface: trimesh.Trimesh, path: str | Path, field: str,
                     check: bool = True) -> trimesh.Trimesh:
    """A repaired copy of ``surface`` (module docstring); with ``check``, one that bounds a
    volume.

    Raises:
        NotWatertightError: open edges or an inconsistent winding remain after repair.
        SelfIntersectionError: triangles cross each other (checked with ``check``).
    """
    import trimesh  # lazily, as in load_surfaces

    mesh = surface.copy()
    vertices = np.array(mesh.vertices)
    vertices[np.abs(vertices[:, 2]) <= BASE_TOLERANCE_M, 2] = 0.0
    mesh.vertices = vertices
    mesh.merge_vertices()
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.update_faces(mesh.unique_faces())
    mesh.remove_unreferenced_vertices()
    trimesh.repair.fill_holes(mesh)
    trimesh.repair.fix_winding(mesh)
    trimesh.repair.fix_inversion(mesh)
    if check and not mesh.is_volume:
        open_edges = len(trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1))
        raise NotWatertightError(
            path, field, f"not a closed volume after repair: {open_edges} open edges "
            f"(holes larger than a quad are not filled), winding consistent "
            f"{mesh.is_winding_consistent}")
    if check:
        _refuse_crossings(mesh, path, field)
    return mesh


def _refuse_crossings(mesh: trimesh.Trimesh, path: str | Path, field: str) -> None:
    """Raise :class:`SelfIntersectionError` when an edge passes through a triangle it does not
    touch (two triangles that cross always have such an edge)."""
    optional("rtree", "mesh", f"{field} (the self-intersection check)")
    edges = mesh.edges_unique
    start, end = mesh.vertices[edges[:, 0]], mesh.vertices[edges[:, 1]]
    length = np.linalg.norm(end - start, axis=1)
    triangles, rays, where = mesh.ray.intersects_id(
        start, (end - start) / length[:, None], multiple_hits=True, return_locations=True)
    touches = (mesh.faces[triangles, :, None] == edges[rays, None, :]).any(axis=(1, 2))
    along = np.linalg.norm(where - start[rays], axis=1)
    crossing = ~touches & (along < length[rays] * (1.0 - 1e-9))
    if crossing.any():
        raise SelfIntersectionError(path, field, f"the surface crosses itself: "
                                    f"{len(np.unique(triangles[crossing]))} triangles are "
                                    f"pierced by its edges")
