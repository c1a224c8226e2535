"""The scene of a cut test: a block of the muscles' tissue on a rigid board, split by the
blade's plane into two halves held by ties, and the blade.

Why two halves. MuJoCo collides a rigid geom with a 3D flex's elements, and a tetrahedron that
straddles the blade's plane stays whole whatever springs inside it are removed, so a blade
cannot pass through one flex. The block is therefore meshed as two flexes that meet on the
blade's plane (the plane a cut test's edge moves in: its edge and its sinking direction), the
plane's vertices doubled, each pair held by a ``connect`` equality: the material's springs
across the plane lumped into one tie per pair, as the paper binds its two muscles. Each pair
lies a contact radius apart, one to either side of the plane (:data:`PARTING_M`), so that the
edge enters between them rather than pressing the top row down head on. Releasing
the ties that the edge has passed (:mod:`cell.cuttest.run`) separates the material behind the
edge, and the cut faces then press on the blade through MuJoCo's contacts, frictionless: the
faces' drag is the cutting model's law over the cut's area (:mod:`cell.cuttest.run`).

The blade is the cell's blade (a box of the blade's thickness and edge length, its height
from edge to spine the cell's :class:`~cell.robots.tools.KnifeParams` width or the block's
height, whichever is larger, so its spine never enters the block) with the bevel of
``edge_angle_deg`` as a wedge along its edge, so that the edge opens a released cut instead of
pressing its faces down. It hangs on three slide joints along the block's axes, its weight
compensated: its position and velocity are written from the logged path before every step
(a mocap body would have no velocity for its contacts' damping).

The block frame is the world frame: the board's top at z = 0.

Example:
    >>> from cell.measure.cuts import Blade, Block
    >>> from cell.tissue.material import default_meat
    >>> scene = build_cut_scene(Block((0.04, 0.03, 0.02)),
    ...     Blade(0.1, 0.0015, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), 20.0),
    ...     default_meat(), plane_m=0.02, cell_size_m=0.01)
    >>> len(scene.ties)
    12
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from cell.collision import FEET, ROBOTS, TABLE_TOP, muscles
from cell.errors import InputError
from cell.measure.cuts import Blade, Block
from cell.robots.tools import KnifeParams
from cell.tissue.flexcomp import flexcomp_xml
from cell.tissue.material import MassSpringMaterial
from cell.tissue.tetmesh import structured_hex_tets

#: The two halves of the block, flex names: the one below the plane's coordinate first.
HALVES = ("near", "far")
#: The blade's contact impedance (MuJoCo's solimp). Stiffer than the cell's knife's
#: (:data:`cell.robots.tools.BLADE_SOLIMP`), which keeps the cell's stiff meat from flinging
#: vertices off the blade at its 5 ms step: chosen when the contacts carried the faces'
#: friction, which with the cell's hardly changed with the friction coefficient.
BLADE_SOLIMP = (0.95, 0.99, 0.001, 0.5, 2.0)
#: solref (time constant s, damping ratio) and solimp of the ties and of the board's contacts:
#: stiff, for MuJoCo scales a soft constraint's stiffness with the vertices' small masses, and
#: the edge's reaction, pressed through the block, sank the feet of a softer board through it.
STIFF_SOLREF = (0.002, 1.0)
STIFF_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)
#: Radius of the spheres under the block's bottom vertices that rest on the board, m.
_FOOT_RADIUS_M = 0.0005
#: Radius of the tissue's contact with the blade (the flexes' collision radius), m.
CONTACT_RADIUS_M = 0.0002
#: How far each of the plane's doubled vertices lies off the plane, to its half's side, m:
#: the ties hold the pair that far apart, their contact spheres touching on the plane, so
#: that the edge enters the block between them. On the plane, the top row met the edge head
#: on and was pressed down with the lattice under it until it slipped aside most of a cell
#: deep: a push on the blade that grew with the cell size, the mesh's own indentation on top
#: of the material's (its ``[cutting]`` ``indentation_depth_m``).
PARTING_M = CONTACT_RADIUS_M
#: The blade's mass while a step's constraints solve, kg: far above a vertex's, so the
#: contacts hardly move it before the path puts it back.
_BLADE_MASS_KG = 1.0
_AXIS_TOLERANCE = 1e-6


@dataclass
class CutScene:
    """A compiled cut-test scene (module docstring).

    Attributes:
        model: the compiled model.
        normal_axis: the block axis (0, 1, 2) along the blade's normal.
        plane_m: the blade plane's coordinate along that axis, m.
        ties: (T,) equality ids of the ties, one per doubled vertex of the plane.
        tie_points_m: (T, 3) their rest positions, m.
        tie_bodies: (T, 2) the two vertex bodies each tie holds.
        blade_body: the blade's body id; ``blade_geoms``: its geom ids (wedge, box).
        blade_qposadr, blade_dofadr: first of the blade's three slide joints' qpos and dofs.
        edge_direction, spine_direction, blade_normal: the blade's frame in the block frame;
            the spine direction points from the edge to the spine.
        cell_size_m: the mesh's cell size, m.
    """

    model: mujoco.MjModel
    normal_axis: int
    plane_m: float
    ties: np.ndarray
    tie_points_m: np.ndarray
    tie_bodies: np.ndarray
    blade_body: int
    blade_geoms: np.ndarray
    blade_qposadr: int
    blade_dofadr: int
    edge_direction: np.ndarray
    spine_direction: np.ndarray
    blade_normal: np.ndarray
    cell_size_m: float


def normal_axis(blade: Blade) -> int:
    """The block axis along the blade's normal.

    Raises:
        InputError: the normal is not along one of the block's axes (the two halves are
            boxes of the block's axes).
    """
    normal = np.abs(np.asarray(blade.blade_normal))
    axis = int(np.argmax(normal))
    if normal[axis] < 1.0 - _AXIS_TOLERANCE:
        raise InputError(None, "blade.blade_normal",
                         "the full simulation cuts along a plane of the block's axes; got "
                         f"{list(blade.blade_normal)}")
    return axis


def spine_direction(blade: Blade, edge_start_m: np.ndarray, block: Block) -> np.ndarray:
    """Unit vector in the blade's plane across the edge, from the edge to the spine: the side
    the blade enters from (away from the block's centre at the path's start)."""
    spine = np.cross(blade.blade_normal, blade.edge_direction)
    outward = np.asarray(edge_start_m) - 0.5 * np.asarray(block.size_m)
    return spine if spine @ outward >= 0.0 else -spine


def _half_grid(block: Block, axis: int, low: float, high: float, cell_size_m: float
               ) -> tuple[np.ndarray, np.ndarray]:
    """Points and tets of the box from ``low`` to ``high`` along ``axis``, the block's extent
    along the others, cells of about ``cell_size_m``."""
    bounds = [(0.0, s) for s in block.size_m]
    bounds[axis] = (low, high)
    counts = tuple(max(1, round((b - a) / cell_size_m)) for a, b in bounds)
    axes = [np.linspace(a, b, n + 1) for (a, b), n in zip(bounds, counts, strict=True)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return points, structured_hex_tets(counts)


def _wedge_vertices(blade: Blade, height_m: float) -> np.ndarray:
    """The bevel as a prism in the blade's frame (x normal, y edge, z spine): edge at z = 0."""
    half_l, half_t = blade.edge_length_m / 2, blade.thickness_m / 2
    return np.array([[x, y, z] for y in (-half_l, half_l)
                     for x, z in ((0.0, 0.0), (-half_t, height_m), (half_t, height_m))])


def _blade_xml(blade: Blade, frame: np.ndarray, reach_m: float, start: np.ndarray
               ) -> tuple[str, str]:
    """The blade's body (the bevel's wedge and the box above it; ``reach_m``, how far the
    block reaches along the spine) and the bevel's mesh asset, as MJCF."""
    angle = math.radians(blade.bevel_deg)
    wedge_h = blade.thickness_m / 2 / math.tan(angle / 2)
    box_h = max(KnifeParams().blade_width_m, reach_m + 0.01)
    wedge = " ".join(f"{v:.9g}" for v in _wedge_vertices(blade, wedge_h).ravel())
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, frame.ravel())
    turn = " ".join(map(str, quat))
    joints = "".join(f'<joint name="blade_{a}" type="slide" axis="{" ".join(map(str, e))}"/>'
                     for a, e in zip("xyz", np.eye(3).astype(int), strict=True))
    geom = (f'contype="{ROBOTS.contype}" conaffinity="{ROBOTS.conaffinity}" '
            f'condim="1" solimp="{" ".join(map(str, BLADE_SOLIMP))}" '
            f'mass="{_BLADE_MASS_KG / 2}" quat="{turn}"')
    body = f"""<body name="blade" pos="{start[0]} {start[1]} {start[2]}" gravcomp="1">
    {joints}
    <geom name="bevel" type="mesh" mesh="bevel" {geom}/>
    <geom name="blade" type="box" pos="{' '.join(map(str, frame[:, 2] * (wedge_h + box_h / 2)))}"
      size="{blade.thickness_m / 2} {blade.edge_length_m / 2} {box_h / 2}" {geom}/>
  </body>"""
    return body, f'<mesh name="bevel" vertex="{wedge}"/>'


def _feet_and_ties(spec: mujoco.MjSpec, halves: list[tuple[np.ndarray, np.ndarray]],
                   axis: int, plane_m: float, board_friction: float) -> np.ndarray:
    """Spheres under the bottom vertices (on the board), and a tie between each pair of
    doubled vertices of the plane; returns the pairs (T, 2) of vertex indices of the halves."""
    for name, (points, _) in zip(HALVES, halves, strict=True):
        for i in np.flatnonzero(points[:, 2] <= 1e-9):
            spec.body(f"{name}_{i}").add_geom(
                type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[_FOOT_RADIUS_M, 0, 0],
                pos=[0, 0, _FOOT_RADIUS_M], mass=1e-9, contype=FEET.contype,
                conaffinity=FEET.conaffinity, friction=[board_friction, 0.005, 0.0001],
                solref=STIFF_SOLREF, solimp=STIFF_SOLIMP)
    near, far = (points for points, _ in halves)
    on_plane = np.flatnonzero(np.abs(near[:, axis] - plane_m) < PARTING_M + 1e-9)
    partner = np.array([np.argmin(np.linalg.norm(far - near[i], axis=1)) for i in on_plane])
    for k, (i, j) in enumerate(zip(on_plane, partner, strict=True)):
        spec.add_equality(name=f"tie_{k}", type=mujoco.mjtEq.mjEQ_CONNECT,
                          objtype=mujoco.mjtObj.mjOBJ_BODY, name1=f"{HALVES[0]}_{i}",
                          name2=f"{HALVES[1]}_{j}", data=np.zeros(12), solref=STIFF_SOLREF,
                          solimp=STIFF_SOLIMP)
    return np.stack([on_plane, partner], axis=1)


def build_cut_scene(block: Block, blade: Blade, material: MassSpringMaterial, plane_m: float,
                    cell_size_m: float, edge_start_m: np.ndarray | None = None,
                    board_friction: float = 1.0,
                    timestep_s: float = 1e-3) -> CutScene:
    """Mesh ``block`` in two halves meeting on the blade's plane at ``plane_m`` (m along the
    normal's axis), put it on the board and add ``blade`` (module docstring).

    ``edge_start_m``: where the edge starts (the spine's side; the block's top centre raised
    by default). The blade's contacts with the tissue are frictionless: the faces' drag is
    the cutting model's (:mod:`cell.cuttest.run`).

    Raises:
        InputError: the normal off the block's axes, or the plane within half a cell of a face.
    """
    axis = normal_axis(blade)
    size = np.asarray(block.size_m)
    if not cell_size_m / 2 <= plane_m <= size[axis] - cell_size_m / 2:
        raise InputError(None, "edge_m", f"the blade's plane at {plane_m:.4g} m is within half "
                         f"a cell ({cell_size_m} m) of the block's faces")
    start = (np.array([*size[:2] / 2, size[2] + 0.01]) if edge_start_m is None
             else np.asarray(edge_start_m, float))
    frame = np.stack([np.asarray(blade.blade_normal), np.asarray(blade.edge_direction),
                      spine_direction(blade, start, block)], axis=1)
    halves = [_half_grid(block, axis, 0.0, plane_m, cell_size_m),
              _half_grid(block, axis, plane_m, size[axis], cell_size_m)]
    for (points, _), side in zip(halves, (-1.0, 1.0), strict=True):
        points[np.abs(points[:, axis] - plane_m) < 1e-9, axis] += side * PARTING_M
    tissue, _ = muscles(False)
    contact = (f'contype="{tissue.contype}" conaffinity="{ROBOTS.conaffinity}" '
               'selfcollide="none" condim="1" solref="0.005 1"')
    flexes = "".join(
        flexcomp_xml(name, points, tets, material,
                     material.density_kg_m3 * np.prod(np.ptp(points, axis=0)),
                     radius_m=CONTACT_RADIUS_M, contact=contact)
        for name, (points, tets) in zip(HALVES, halves, strict=True))
    blade_body, bevel = _blade_xml(blade, frame, size @ np.abs(frame[:, 2]), start)
    stiff_solref, stiff_solimp = (" ".join(map(str, v)) for v in (STIFF_SOLREF, STIFF_SOLIMP))
    spec = mujoco.MjSpec.from_string(f"""<mujoco model="cut_test">
<option timestep="{timestep_s}" integrator="implicitfast" solver="CG" cone="elliptic"/>
<asset>{bevel}</asset>
<worldbody>
  <geom name="board" type="box" size="{size[0]} {size[1]} 0.05"
    pos="{size[0] / 2} {size[1] / 2} -0.05" friction="{board_friction} 0.005 0.0001"
    solref="{stiff_solref}" solimp="{stiff_solimp}"
    contype="{TABLE_TOP.contype}" conaffinity="{TABLE_TOP.conaffinity}"/>
  {flexes}
  {blade_body}
</worldbody></mujoco>""")
    pairs = _feet_and_ties(spec, halves, axis, plane_m, board_friction)
    model = spec.compile()
    ties = np.array([model.equality(f"tie_{k}").id for k in range(len(pairs))], dtype=int)
    bodies = np.array([[model.body(f"{HALVES[0]}_{i}").id, model.body(f"{HALVES[1]}_{j}").id]
                       for i, j in pairs], dtype=int)
    joint = model.joint("blade_x").id
    return CutScene(model, axis, plane_m, ties, halves[0][0][pairs[:, 0]], bodies.reshape(-1, 2),
                    model.body("blade").id,
                    np.array([model.geom("bevel").id, model.geom("blade").id]),
                    int(model.jnt_qposadr[joint]), int(model.jnt_dofadr[joint]),
                    frame[:, 1].copy(), frame[:, 2].copy(), frame[:, 0].copy(), cell_size_m)
