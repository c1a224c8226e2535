"""CAD parts of the cell (a knife handle, a fixture clamp, gripper fingers) from STL or OBJ
meshes: the visual mesh whole, the collision geometry its convex pieces from coacd.

MuJoCo collides a mesh geom as its convex hull, so a concave part (a bowed handle, an arch)
needs an approximate convex decomposition: coacd (``cad`` extra) cuts it into pieces whose
concavity stays under ``concavity`` (a fraction of the part's size). Decomposition takes
seconds, so its pieces are cached by the SHA-256 of the mesh file and the settings, in
``$MUSCLECELL_CACHE_DIR`` or the user's cache folder (``platformdirs``), one ``.npz`` a mesh,
written atomically. Meshes are in metres, in the frame of the body they are added to.

Example:
    >>> import mujoco
    >>> part = decompose("assets/meshes/tools/boning_knife_handle.stl", "knife.handle_mesh")
    >>> len(part.pieces) >= 1, abs(part.volume_error) < 0.1
    (True, True)
    >>> spec = mujoco.MjSpec()
    >>> add_part(spec, spec.worldbody.add_body(name="knife"), "handle", part, mass_kg=0.15)
    >>> model = spec.compile()
"""

from __future__ import annotations

import hashlib
import io
import os
import time
from dataclasses import dataclass
from importlib.metadata import version
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from cell.collision import ROBOTS, Collision
from cell.errors import MeshError, NotWatertightError
from cell.extras import optional
from cell.io import read_bytes
from cell.outputs import write_atomic

if TYPE_CHECKING:
    import trimesh

#: coacd's concavity threshold (its ``threshold``, a fraction of the part's bounding box
#: diagonal): 0.05 is its default, and keeps the example parts' hull volume within 10 %.
CONCAVITY = 0.05
#: The environment variable that moves the decomposition cache.
CACHE_ENV = "MUSCLECELL_CACHE_DIR"
_SEED = 0


@dataclass(frozen=True, eq=False)
class ConvexParts:
    """A CAD part: its whole surface and its convex pieces (m).

    Attributes:
        source: the mesh file.
        mesh: the whole surface, for the visual geom.
        pieces: the convex pieces, for the collision geoms.
        volume_error: the pieces' total volume over the mesh's, less 1 (their overlap and
            the hulls' excess over the concave surface).
        cache_hit: the pieces came from the cache.
        seconds: time to decompose (or to read the cache), s.
    """

    source: str
    mesh: trimesh.Trimesh
    pieces: tuple[trimesh.Trimesh, ...]
    volume_error: float
    cache_hit: bool
    seconds: float

    def figures(self) -> dict[str, object]:
        """What a summary's result gives (the same on every run): file name, piece count,
        volume error."""
        return {"source": Path(self.source).name, "pieces": len(self.pieces),
                "volume_error": self.volume_error}

    def timing(self) -> dict[str, object]:
        """What a summary's timing gives: the cache hit and the time it took, s."""
        return {"cache_hit": self.cache_hit, "seconds": self.seconds}


def cache_folder() -> Path:
    """Where decompositions are kept: ``$MUSCLECELL_CACHE_DIR``, else the user's cache
    folder for musclecell, under ``coacd``."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV]) / "coacd"
    platformdirs = optional("platformdirs", "cad", "CAD meshes (the decomposition cache)")
    return Path(platformdirs.user_cache_dir("musclecell")) / "coacd"


def decompose(path: str | Path, field: str, concavity: float = CONCAVITY) -> ConvexParts:
    """The convex pieces of the closed mesh file ``path`` (``field`` names the key that gave
    it), from the cache when it has them.

    Raises:
        MeshError: the file cannot be read or holds no triangles.
        NotWatertightError: the mesh is not a closed volume.
        MissingExtraError: coacd is not installed (``pip install 'musclecell[cad]'``).
    """
    import trimesh  # only here: an episode that reads no mesh file starts without it

    start = time.perf_counter()
    content = read_bytes(path, "mesh", MeshError)
    try:
        mesh = trimesh.load(io.BytesIO(content), file_type=Path(path).suffix.lstrip("."),
                            force="mesh")
    except (OSError, ValueError, KeyError, IndexError) as exc:
        raise MeshError(path, field, f"cannot read the mesh: {exc}") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise MeshError(path, field, "holds no triangles")
    if not mesh.is_volume:
        raise NotWatertightError(path, field, f"not a closed volume (watertight "
                                 f"{mesh.is_watertight}, winding consistent "
                                 f"{mesh.is_winding_consistent})")
    coacd = optional("coacd", "cad", f"{field} (a CAD mesh to decompose)")
    key = hashlib.sha256(content + f"|{concavity}|{_SEED}|{coacd_version()}".encode()
                         ).hexdigest()
    cached = cache_folder() / f"{key}.npz"
    hit = cached.is_file()
    if hit:
        with np.load(cached) as stored:
            arrays = [(stored[f"v{i}"], stored[f"f{i}"]) for i in range(int(stored["count"]))]
    else:
        coacd.set_log_level("error")
        arrays = coacd.run_coacd(coacd.Mesh(mesh.vertices, mesh.faces), threshold=concavity,
                                 seed=_SEED)
        buffer = io.BytesIO()
        np.savez(buffer, count=len(arrays), **{f"v{i}": v for i, (v, _) in enumerate(arrays)},
                 **{f"f{i}": f for i, (_, f) in enumerate(arrays)})
        write_atomic(cached, buffer.getvalue())
    pieces = tuple(trimesh.Trimesh(v, f).convex_hull for v, f in arrays)
    error = sum(piece.volume for piece in pieces) / mesh.volume - 1.0
    return ConvexParts(str(path), mesh, pieces, float(error), hit,
                       time.perf_counter() - start)


def coacd_version() -> str:
    """The installed coacd's version (part of the cache key: another coacd may cut
    otherwise)."""
    return version("coacd")


def add_part(spec: mujoco.MjSpec, body: mujoco.MjsBody, name: str, part: ConvexParts,
             mass_kg: float | None = None, pos: tuple[float, float, float] = (0.0, 0.0, 0.0),
             rgba: tuple[float, float, float, float] = (0.1, 0.1, 0.1, 1.0),
             collision: Collision = ROBOTS) -> None:
    """Add ``part`` to ``body`` at ``pos`` (m, body frame): a visual geom ``name`` of the whole
    mesh (no contacts, no mass) and collision geoms ``name_0``, ``name_1``, ... of its pieces
    (hidden, group 3) with ``collision``'s bits, sharing ``mass_kg`` by volume (None: a
    static body's, massless)."""
    spec.add_mesh(name=name, uservert=part.mesh.vertices.ravel(),
                  userface=part.mesh.faces.ravel())
    body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name, pos=pos,
                  rgba=list(rgba), contype=0, conaffinity=0, density=0.0, group=1)
    volumes = np.array([piece.volume for piece in part.pieces])
    for i, piece in enumerate(part.pieces):
        spec.add_mesh(name=f"{name}_{i}", uservert=piece.vertices.ravel(),
                      userface=piece.faces.ravel())
        mass = 0.0 if mass_kg is None else mass_kg * volumes[i] / volumes.sum()
        body.add_geom(name=f"{name}_{i}", type=mujoco.mjtGeom.mjGEOM_MESH,
                      meshname=f"{name}_{i}", pos=pos, rgba=list(rgba), group=3,
                      contype=collision.contype, conaffinity=collision.conaffinity,
                      mass=mass)
