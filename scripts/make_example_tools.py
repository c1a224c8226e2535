"""Write the example CAD tools: a boning knife's curved handle and a U-shaped fixture clamp,
as binary STL in metres, each in its own frame (see ``[knife] handle_mesh`` and
``[fixture] clamp_mesh`` in docs/scenarios.md). Both are non-convex, so coacd cuts them into
several convex pieces.

- The handle: a capsule of radius ``HANDLE_RADIUS_M`` along +z from 0 to
  ``HANDLE_LENGTH_M`` with an oval section (narrower along y, the blade's thickness), bowed
  toward -x (the spine's side) by ``HANDLE_BOW_M`` in the middle, its ends on the tool axis:
  a palm swell.
- The clamp: a bar (``CLAMP_DEPTH_M`` along y, ``CLAMP_THICKNESS_M`` thick) bent by 180
  degrees into an arch of radius ``CLAMP_RADIUS_M`` in the x-z plane, its two feet on z = 0
  at x = +-``CLAMP_RADIUS_M``, its face toward the meat on y = 0: it stands against the
  round's outer wall and holds it along the arch.

Usage::

    PYTHONPATH=. python scripts/make_example_tools.py assets/meshes/tools
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import trimesh

from cell.outputs import write_atomic

HANDLE_RADIUS_M = 0.016
HANDLE_LENGTH_M = 0.12
HANDLE_BOW_M = 0.012
HANDLE_OVAL = 0.7
CLAMP_DEPTH_M = 0.02
CLAMP_THICKNESS_M = 0.012
CLAMP_RADIUS_M = 0.06


def bent(mesh: trimesh.Trimesh, radius_m: float, along: int, toward: int) -> trimesh.Trimesh:
    """``mesh`` bent about an axis: coordinate ``along`` (from 0) becomes an arc of radius
    ``radius_m`` that turns toward axis ``toward``; volume is kept for thin parts."""
    v = np.array(mesh.vertices)
    angle = v[:, along] / radius_m
    offset = radius_m - v[:, toward]
    v[:, toward] = radius_m - offset * np.cos(angle)
    v[:, along] = offset * np.sin(angle)
    return trimesh.Trimesh(v, mesh.faces, process=True)


def handle() -> trimesh.Trimesh:
    core = trimesh.creation.capsule(height=HANDLE_LENGTH_M - 2 * HANDLE_RADIUS_M,
                                    radius=HANDLE_RADIUS_M, count=[24, 12])
    core.apply_translation((0.0, 0.0, HANDLE_LENGTH_M / 2 - core.bounds[:, 2].mean()))
    core.apply_scale((1.0, HANDLE_OVAL, 1.0))
    core = _subdivided(core, 0.012)  # rings along the straight part, for the bow to bend
    vertices = np.array(core.vertices)
    vertices[:, 0] -= HANDLE_BOW_M * np.sin(np.pi * vertices[:, 2] / HANDLE_LENGTH_M)
    return trimesh.Trimesh(vertices, core.faces, process=True)


def clamp() -> trimesh.Trimesh:
    bar = trimesh.creation.box((np.pi * CLAMP_RADIUS_M, CLAMP_DEPTH_M, CLAMP_THICKNESS_M))
    bar = _subdivided(bar, 0.012)
    bar.apply_translation((0.0, -CLAMP_DEPTH_M / 2, CLAMP_THICKNESS_M / 2))
    cup = bent(bar, CLAMP_RADIUS_M, along=0, toward=2)  # a U: bottom at z = 0, tips at R
    cup.apply_transform(np.diag([1.0, 1.0, -1.0, 1.0]))  # upside down: an arch
    cup.apply_translation((0.0, 0.0, -cup.bounds[0, 2]))
    return cup


def _subdivided(mesh: trimesh.Trimesh, max_edge_m: float) -> trimesh.Trimesh:
    vertices, faces = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge_m)
    return trimesh.Trimesh(vertices, faces, process=True)


def main(folder: str) -> None:
    for name, mesh in (("boning_knife_handle", handle()), ("fixture_clamp", clamp())):
        assert mesh.is_volume, name
        stl = mesh.export(file_type="stl")
        print(name, write_atomic(Path(folder) / f"{name}.stl", stl), len(stl), "bytes",
              mesh.bounds.round(3).tolist())


if __name__ == "__main__":
    main(sys.argv[1])
