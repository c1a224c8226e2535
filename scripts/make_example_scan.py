"""Write the example scan: the procedural round and shank's surfaces as a scanner would give
them, with noise and holes, so that a scenario exercises the repair path of
:mod:`cell.tissue.surface`.

The truth is the default :class:`~cell.tissue.geometry.MuscleShape` meshed at
``CELL_SIZE_M``; each muscle's boundary surface moves every vertex along its normal by
N(0, ``NOISE_M``) (a scanner's depth noise; the bottom, on the table, moves along it only in
the plane) and loses ``HOLES`` faces or adjacent face pairs far apart (dropouts the repair
fills: a scanner's missing triangles). One generator, seeded once with ``SEED``, draws the
noise and the holes, round first. Each file is a binary PLY in metres, in the meat's frame.

Usage::

    PYTHONPATH=. python scripts/make_example_scan.py assets/meshes/scan
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import trimesh

from cell.outputs import write_atomic
from cell.tissue.geometry import MuscleShape, build_two_muscles

CELL_SIZE_M = 0.035
NOISE_M = 0.0004
HOLES = 4
SEED = 16


def scanned(surface: trimesh.Trimesh, rng: np.random.Generator) -> trimesh.Trimesh:
    """``surface`` with normal noise and holes of one or two faces."""
    normals = np.array(surface.vertex_normals)
    bottom = np.isclose(surface.vertices[:, 2], 0.0)
    normals[bottom, 2] = 0.0  # the table keeps the base flat
    vertices = surface.vertices + normals * rng.normal(0.0, NOISE_M, (len(normals), 1))
    keep = np.ones(len(surface.faces), dtype=bool)
    centres = surface.triangles_center
    chosen: list[int] = []
    for face in rng.permutation(len(surface.faces)):
        if len(chosen) == HOLES:
            break
        if chosen and np.linalg.norm(centres[chosen] - centres[face], axis=1).min() < 0.1:
            continue
        chosen.append(int(face))
        keep[face] = False
        if len(chosen) % 2 == 0:  # every second hole a quad: the face and a neighbour
            pairs = surface.face_adjacency
            keep[pairs[pairs[:, 0] == face, 1][:1]] = False
    return trimesh.Trimesh(vertices, surface.faces[keep], process=False)


def main(folder: str) -> None:
    rng = np.random.default_rng(SEED)
    mesh = build_two_muscles(MuscleShape(cell_size_m=CELL_SIZE_M))
    for name, muscle in (("round", mesh.round), ("shank", mesh.shank)):
        surface = trimesh.Trimesh(muscle.points, muscle.boundary, process=True)
        ply = scanned(surface, rng).export(file_type="ply", encoding="binary")
        print(name, write_atomic(Path(folder) / f"{name}.ply", ply), len(ply), "bytes")


if __name__ == "__main__":
    main(sys.argv[1])
