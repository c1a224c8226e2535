"""Closed surfaces filled with tetrahedra by TetGen (the ``tetgen`` wrapper, ``mesh`` extra).

TetGen keeps the surface and adds Steiner points where the quality bounds need them: a
radius-edge ratio of at most :data:`MAX_RADIUS_EDGE_RATIO`, dihedral angles of at least
:data:`MIN_DIHEDRAL_DEG` where it can reach them, and no tet larger than a regular one of edge
``cell_size_m``; then its optimisation flips and smooths until no dihedral angle passes
:data:`MAX_DIHEDRAL_DEG` (slivers have both a tiny and a near-flat angle). Slivers against a
scan's nearly flat facets can remain; the episode's summary reports the smallest angle. On the
example scan these settings raise the smallest angle well above what TetGen's ``-q2/10`` leaves,
for a few more nodes (``docs/benchmarks.md``). TetGen itself is AGPL-3.0 (its Python wrapper
MIT): it is an optional extra, never a dependency of the package.

Example:
    >>> import trimesh
    >>> box = trimesh.creation.box((0.1, 0.06, 0.05))
    >>> mesh = tetrahedralise(box, "box.ply", "tissue.surface_mesh", cell_size_m=0.03)
    >>> round(mesh.volume_m3, 6)
    0.0003
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from cell.errors import (
    MeshError,
    SelfIntersectionError,
    TetrahedralisationError,
)
from cell.extras import optional
from cell.tissue.tetmesh import TetMesh

if TYPE_CHECKING:
    import trimesh

MAX_RADIUS_EDGE_RATIO = 1.6
MIN_DIHEDRAL_DEG = 15.0
MAX_DIHEDRAL_DEG = 140.0
_OPTIMISATION_PASSES = 50
_REGULAR_TET_VOLUME = 1.0 / (6.0 * np.sqrt(2.0))


def tetrahedralise(surface: trimesh.Trimesh, path: str | Path, field: str,
                   cell_size_m: float) -> TetMesh:
    """Fill the closed ``surface`` (m) with tets of edge about ``cell_size_m`` or shorter.

    Args:
        surface: a closed, outward-wound surface (see :mod:`cell.tissue.surface`).
        path, field: the file and the key it came from, named in errors.
        cell_size_m: target tet edge, m.

    Raises:
        MissingExtraError: ``tetgen`` is not installed (``pip install 'musclecell[mesh]'``).
        SelfIntersectionError: triangles of the surface cross each other.
        TetrahedralisationError: TetGen fails, or its tets do not make a valid flex.
    """
    tetgen = optional("tetgen", "mesh", f"{field} (a surface mesh to tetrahedralise)")
    generator = tetgen.TetGen(np.asarray(surface.vertices, dtype=float),
                              np.asarray(surface.faces, dtype=np.int32))
    try:
        nodes, elements = generator.tetrahedralize(
            minratio=MAX_RADIUS_EDGE_RATIO, mindihedral=MIN_DIHEDRAL_DEG,
            optmaxdihedral=MAX_DIHEDRAL_DEG, opt_iterations=_OPTIMISATION_PASSES,
            maxvolume=_REGULAR_TET_VOLUME * cell_size_m**3, quiet=True)[:2]
    except (RuntimeError, ValueError) as exc:
        if "self-intersect" in str(exc):
            raise SelfIntersectionError(path, field, f"the surface crosses itself ({exc})"
                                        ) from None
        raise TetrahedralisationError(path, field, f"TetGen failed: {exc}") from None
    if len(elements) == 0:
        raise TetrahedralisationError(path, field, "TetGen made no tets")
    # TetGen orients its tets the other way round from MuJoCo's flexes.
    tets = np.asarray(elements, dtype=np.int64)[:, [0, 2, 1, 3]]
    try:
        return TetMesh.from_arrays(nodes, tets, str(path))
    except MeshError as exc:
        raise TetrahedralisationError(path, field, f"TetGen's tets are not a valid flex: "
                                      f"{exc.field}: {exc.message}") from None
