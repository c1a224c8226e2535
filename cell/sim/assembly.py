"""The cell as one MuJoCo model: three arms with their tools, the table and holding system, and
the two muscles bound by the aponeurosis.

Composition goes through :class:`mujoco.MjSpec`: arms are attached under a prefix on frames of
the world, tools on the arms' ``flange`` sites. The muscles are ``flexcomp`` soft bodies (the
one element MjSpec cannot build from arrays, so they come from a small generated MJCF
fragment). The round's bottom is pinned to the holding plate, whose force sensor is the
paper's dynamometer.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from cell.collision import FEET, TABLE_TOP, muscles
from cell.errors import MaterialError, MeshError
from cell.outputs import write_atomic
from cell.robots.cad import ConvexParts, add_part, decompose
from cell.robots.names import GRIPPER_BODY
from cell.robots.tools import build_camera, build_gripper, build_knife
from cell.sim.scenario import Scenario
from cell.tissue.aponeurosis import Aponeurosis, BindingLaw
from cell.tissue.flexcomp import flexcomp_xml, set_continuum_law
from cell.tissue.geometry import TetMesh, TwoMuscleMesh
from cell.tissue.material import ContinuumMaterial
from cell.tissue.scan import build_tissue

#: Rest height of the bottom layer: vertices within this of the table are pinned (round) or
#: stand on feet (shank).
_PIN_TOLERANCE_M = 1e-6
_FOOT_RADIUS_M = 0.002


@dataclass
class Scene:
    """A compiled cell and the indices the runtime needs.

    Attributes:
        scenario: what it was built from.
        spec: the composed :class:`mujoco.MjSpec` (kept for export).
        model: the compiled model.
        mesh: the two muscles' tetrahedral meshes in world coordinates, m.
        round_bodies, shank_bodies: body id of each mesh vertex (the holding plate's id for
            pinned round vertices).
        aponeurosis: the bindings; their release record belongs to the episode on the scene
            and :meth:`restore` clears it.
        grasp_equalities: ids of the inactive gripper-to-vertex ``connect`` equalities (none
            in a scene without robots).
        grasp_vertices: shank vertex index of each grasp equality.
        eq_data0: ``model.eq_data`` as built, for :meth:`restore`.
        cad_parts: the CAD parts' decompositions by scenario key (``knife.handle_mesh``,
            ``fixture.clamp_mesh``), for the summary.

    Example:
        >>> from cell.sim.scenario import Scenario
        >>> from cell.tissue.geometry import MuscleShape
        >>> scene = build_scene(Scenario(tissue=MuscleShape(cell_size_m=0.05)), robots=False)
        >>> scene.node_count, scene.model.nflexvert
        (240, 240)
    """

    scenario: Scenario
    spec: mujoco.MjSpec
    model: mujoco.MjModel
    mesh: TwoMuscleMesh
    round_bodies: np.ndarray
    shank_bodies: np.ndarray
    aponeurosis: Aponeurosis
    grasp_equalities: np.ndarray
    grasp_vertices: np.ndarray
    eq_data0: np.ndarray
    cad_parts: dict[str, ConvexParts] = field(default_factory=dict)

    @property
    def node_count(self) -> int:
        """Number of tissue vertices (both muscles)."""
        return len(self.round_bodies) + len(self.shank_bodies)

    @property
    def tissue_bodies(self) -> np.ndarray:
        """Body id of every tissue vertex, round then shank."""
        return np.concatenate([self.round_bodies, self.shank_bodies])

    def restore(self, data: mujoco.MjData) -> None:
        """Undo what an episode wrote into the scene, so that the next starts as the first:
        every binding bound again (``data``'s binding equalities and the release record),
        the grasp anchors back as built (a grasp writes them into ``model.eq_data``)."""
        self.aponeurosis.reset(data)
        self.model.eq_data[:] = self.eq_data0


def _yaw_quat(yaw_deg: float) -> list[float]:
    half = np.deg2rad(yaw_deg) / 2
    return [float(np.cos(half)), 0.0, 0.0, float(np.sin(half))]


def integrator(scenario: Scenario, actuated: bool = True) -> mujoco.mjtIntegrator:
    """MuJoCo's integrator for the scenario: ``discrete`` for flex continuum elasticity (the
    only one that runs it), ``implicitfast`` for the mass-spring model (its springs come in as
    applied forces; the arms' actuators stay implicit), ``euler`` for it in a scene without
    ``actuated`` arms (nothing there for ``implicitfast`` to take implicitly, and the muscles
    alone step faster with ``euler``), or the one asked for."""
    choice = scenario.simulation.integrator
    if choice == "auto":
        choice = ("discrete" if isinstance(scenario.material, ContinuumMaterial)
                  else "implicitfast" if actuated else "euler")
    return {"discrete": mujoco.mjtIntegrator.mjINT_DISCRETE,
            "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
            "euler": mujoco.mjtIntegrator.mjINT_EULER}[choice]


def build_robot_spec(scenario: Scenario, spec: mujoco.MjSpec | None = None,
                     robots: bool = True, handle: ConvexParts | None = None) -> mujoco.MjSpec:
    """World, floor, table and the three arms with their tools (not with ``robots=False``),
    added to ``spec`` (a new one by default, which then holds no tissue); ``handle``: the
    knife's CAD handle, if decomposed already.

    The tissue-free spec serves as the IK model, whose joints match the full scene by name.
    """
    spec = mujoco.MjSpec() if spec is None else spec
    spec.modelname = "musclecell"
    sim = scenario.simulation
    spec.option.timestep = sim.timestep_s
    spec.option.integrator = integrator(scenario, actuated=robots)
    spec.option.iterations = sim.solver_iterations
    # CG with elliptic cones solves the flex-table contacts of the default cell faster than
    # Newton with pyramids, to the same resting state.
    spec.option.solver = mujoco.mjtSolver.mjSOL_CG
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.visual.global_.offwidth = max(640, scenario.camera.width_px)
    spec.visual.global_.offheight = max(480, scenario.camera.height_px)
    spec.stat.center = [0.0, 0.0, scenario.layout.table_height_m]
    spec.stat.extent = 1.5
    world = spec.worldbody
    world.add_light(name="key", pos=[0.5, -0.5, 3.0], dir=[-0.2, 0.2, -1.0], castshadow=False)
    world.add_light(name="fill", pos=[-1.0, 1.0, 2.5], dir=[0.4, -0.4, -1.0], castshadow=False)
    world.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[3, 3, 0.1],
                   rgba=[0.35, 0.37, 0.4, 1], contype=0, conaffinity=0)
    layout = scenario.layout
    table_half = [0.45, 0.40, layout.table_height_m / 2]
    world.add_geom(name="table", type=mujoco.mjtGeom.mjGEOM_BOX, size=table_half,
                   pos=[layout.meat_x_m, 0.0, layout.table_height_m / 2],
                   rgba=[0.75, 0.76, 0.78, 1], contype=TABLE_TOP.contype,
                   conaffinity=TABLE_TOP.conaffinity,
                   friction=[sim.table_friction, 0.005, 0.0001])
    if robots:
        _add_arms(scenario, spec, handle)
    return spec


def _add_arms(scenario: Scenario, spec: mujoco.MjSpec, handle: ConvexParts | None = None
              ) -> None:
    """The three arms on their bases, each with its tool on its flange (the knife's CAD
    handle ``handle``, if decomposed already)."""
    layout = scenario.layout
    world = spec.worldbody
    tools = {
        "knife_arm": ("knife/", build_knife(scenario.knife, handle)),
        "pull_arm": ("gripper/", build_gripper(scenario.gripper)),
        "camera_arm": ("camera/", build_camera(scenario.camera)),
    }
    bases = {
        "knife_arm": layout.knife_arm_base,
        "pull_arm": layout.pull_arm_base,
        "camera_arm": layout.camera_arm_base,
    }
    for prefix, arm in scenario.arms.cell_arms().items():
        x, y, z, yaw = bases[prefix]
        frame = world.add_frame(pos=[x, y, z], quat=_yaw_quat(yaw))
        spec.attach(arm.spec(), frame=frame, prefix=f"{prefix}/")
        tool_prefix, tool = tools[prefix]
        spec.attach(tool, site=spec.site(f"{prefix}/flange"), prefix=tool_prefix)


def _muscle_xml(name: str, mesh: TetMesh, scenario: Scenario, pins: np.ndarray,
                offset_m: np.ndarray) -> str:
    """A flexcomp for one muscle, points shifted by ``offset_m`` into the parent body's frame."""
    material = scenario.material
    round_bits, shank_bits = muscles(scenario.simulation.muscle_contact)
    bits = round_bits if name == "round" else shank_bits
    contact = (f'contype="{bits.contype}" conaffinity="{bits.conaffinity}" selfcollide="none" '
               f'condim="3" friction="{scenario.simulation.tissue_friction} 0.005 0.0001" '
               'solref="0.005 1"')
    return flexcomp_xml(name, mesh.points + offset_m, mesh.tets, material,
                        material.density_kg_m3 * mesh.volume_m3, radius_m=0.0005,
                        contact=contact, pins=pins.tolist(),
                        rgba="0.72 0.20 0.22 1" if name == "round" else "0.80 0.36 0.30 1")


def _tissue_spec(scenario: Scenario, mesh: TwoMuscleMesh, round_pins: np.ndarray) -> str:
    layout = scenario.layout
    origin = np.array([layout.meat_x_m, 0.0, layout.table_height_m])
    # Under the round: as long as the muscles and a little wider than the round.
    length_m = np.ptp(mesh.round.points[:, 0])
    width_m = origin[1] - mesh.round.points[:, 1].min()
    plate_half = [length_m / 2 + 0.03, width_m / 2 + 0.02, 0.002]
    plate_y = -width_m / 2
    return f"""<mujoco><worldbody>
  <body name="fixture" pos="{origin[0]} {origin[1]} {origin[2]}">
    <site name="dynamometer" size="0.01"/>
    <geom name="plate" type="box" size="{plate_half[0]} {plate_half[1]} {plate_half[2]}"
      pos="0 {plate_y} {-plate_half[2]}" rgba="0.6 0.62 0.65 1" contype="0" conaffinity="0"/>
    {_muscle_xml("round", mesh.round, scenario, round_pins, -origin)}
  </body>
  {_muscle_xml("shank", mesh.shank, scenario, np.zeros(0, dtype=int), np.zeros(3))}
</worldbody>
<sensor><force name="fixture_force" site="dynamometer"/></sensor>
</mujoco>"""


def build_scene(scenario: Scenario, robots: bool = True) -> Scene:
    """Compose and compile the whole cell for ``scenario``; with ``robots=False`` only the
    muscles, the fixture and the table (no arms, tools, grasp or tool sensors).

    The tissue comes first in the model, so its body ids are the same with and without the
    robots.
    """
    layout = scenario.layout
    origin = np.array([layout.meat_x_m, 0.0, layout.table_height_m])
    mesh = build_tissue(scenario.tissue, origin_m=tuple(origin))
    round_pins = np.flatnonzero(mesh.round.points[:, 2] <= origin[2] + _PIN_TOLERANCE_M)
    # flexcomp is the one element MjSpec cannot build from arrays: start from its MJCF.
    spec = mujoco.MjSpec.from_string(_tissue_spec(scenario, mesh, round_pins))
    set_continuum_law(spec, scenario.material)
    _add_feet(spec, mesh, origin[2], scenario.simulation.table_friction)
    parts = _cad_parts(scenario, robots)
    if "fixture.clamp_mesh" in parts:
        _add_clamp(spec, mesh, origin, scenario.fixture.clearance_m, parts["fixture.clamp_mesh"])
    build_robot_spec(scenario, spec, robots, parts.get("knife.handle_mesh"))

    apo = scenario.aponeurosis
    law = BindingLaw(apo.law)
    if law is BindingLaw.CONSTRAINT:
        pinned = set(round_pins.tolist())
        for k, (r, s) in enumerate(mesh.pairs):
            # A pinned round vertex is a point of the fixture: anchor the binding there.
            body, anchor = (("fixture", mesh.round.points[r] - origin) if r in pinned
                            else (f"round_{r}", np.zeros(3)))
            spec.add_equality(name=f"binding_{k}", type=mujoco.mjtEq.mjEQ_CONNECT,
                              objtype=mujoco.mjtObj.mjOBJ_BODY, name1=body,
                              name2=f"shank_{s}", data=[*anchor, *np.zeros(9)],
                              solref=[apo.timeconst_s, apo.dampratio])
    grasp_vertices = (_grasp_candidates(scenario, mesh) if robots
                      else np.zeros(0, dtype=int))
    for v in grasp_vertices:
        spec.add_equality(name=f"grasp_{v}", type=mujoco.mjtEq.mjEQ_CONNECT,
                          objtype=mujoco.mjtObj.mjOBJ_BODY, name1=GRIPPER_BODY,
                          name2=f"shank_{v}", active=False, solref=[0.01, 1.0])
    model = spec.compile()
    round_bodies = _vertex_bodies(model, "round", len(mesh.round.points), "fixture")
    shank_bodies = _vertex_bodies(model, "shank", len(mesh.shank.points), None)
    binding_ids = (np.array([model.equality(f"binding_{k}").id for k in range(len(mesh.pairs))])
                   if law is BindingLaw.CONSTRAINT else None)
    grasp_ids = np.array([model.equality(f"grasp_{v}").id for v in grasp_vertices], dtype=int)
    round_vertex0 = model.flex_vertadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_FLEX,
                                                         "round")]
    shank_vertex0 = model.flex_vertadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_FLEX,
                                                         "shank")]
    aponeurosis = Aponeurosis(model, round_vertex0 + mesh.pairs[:, 0],
                              shank_vertex0 + mesh.pairs[:, 1], round_bodies[mesh.pairs[:, 0]],
                              shank_bodies[mesh.pairs[:, 1]], mesh.pairs, law=law,
                              stiffness_n_m=apo.stiffness_n_m,
                              damping_n_s_m=apo.damping_n_s_m, equality_ids=binding_ids)
    return Scene(scenario, spec, model, mesh, round_bodies, shank_bodies, aponeurosis,
                 grasp_ids, grasp_vertices, model.eq_data.copy(), parts)


def _cad_parts(scenario: Scenario, robots: bool) -> dict[str, ConvexParts]:
    """The scenario's CAD parts decomposed (the knife's only in a scene with robots)."""
    files = {"fixture.clamp_mesh": scenario.fixture.clamp_mesh}
    if robots:
        files["knife.handle_mesh"] = scenario.knife.handle_mesh
    return {key: decompose(path, key) for key, path in files.items() if path}


def _add_clamp(spec: mujoco.MjSpec, mesh: TwoMuscleMesh, origin: np.ndarray,
               clearance_m: float, clamp: ConvexParts) -> None:
    """The CAD clamp on the fixture, against the middle of the round's outer wall's foot."""
    points = mesh.round.points
    middle_x = 0.5 * (points[:, 0].min() + points[:, 0].max())
    foot = np.array([middle_x, points[:, 1].min() - clearance_m, origin[2]]) - origin
    add_part(spec, spec.body("fixture"), "clamp", clamp, pos=tuple(foot),
             rgba=(0.45, 0.47, 0.5, 1.0))


def _add_feet(spec: mujoco.MjSpec, mesh: TwoMuscleMesh, table_z_m: float,
              friction: float) -> None:
    """A small sphere under every bottom vertex of the shank, resting on the table (see
    :data:`cell.collision.FEET`). Its bottom touches the vertex, so the rest pose is kept;
    it has the table's ``friction`` (a contact takes the larger of the two)."""
    bottom = np.flatnonzero(mesh.shank.points[:, 2] <= table_z_m + _PIN_TOLERANCE_M)
    for i in bottom:
        spec.body(f"shank_{i}").add_geom(
            name=f"shank_foot_{i}", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[_FOOT_RADIUS_M, 0, 0],
            pos=[0, 0, _FOOT_RADIUS_M], mass=1e-9, contype=FEET.contype,
            conaffinity=FEET.conaffinity, friction=[friction, 0.005, 0.0001], group=3)


def _vertex_bodies(model: mujoco.MjModel, flex: str, count: int, pin_body: str | None
                   ) -> np.ndarray:
    """Body id of every vertex of ``flex``; pinned vertices belong to ``pin_body``."""
    ids = np.empty(count, dtype=int)
    fallback = -1 if pin_body is None else model.body(pin_body).id
    for i in range(count):
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"{flex}_{i}")
        ids[i] = body if body >= 0 else fallback
    if (ids < 0).any():
        raise MeshError(None, f"flex {flex}", "vertices without bodies")
    return ids


def _grasp_candidates(scenario: Scenario, mesh: TwoMuscleMesh) -> np.ndarray:
    """Shank vertices that the gripper may bind: those near the planned grasp point."""
    target = grasp_point(scenario, mesh)
    distance = np.linalg.norm(mesh.shank.points - target, axis=1)
    return np.flatnonzero(distance < 2.0 * scenario.pull.grasp_radius_m)


def grasp_point(scenario: Scenario, mesh: TwoMuscleMesh) -> np.ndarray:
    """World point (m) where the jaws' centre goes: ``grasp_depth_m`` below the shank's top,
    ``grasp_inset_m`` in from its outer side, at ``grasp_x_fraction`` of its length, moved to
    the nearest column of mesh vertices so that the jaws close on some. Only columns that
    rise within ``grasp_depth_m`` of the shank's top count: on a coarse mesh the nearest may
    stand on the rounded edge, so low that the tilted palm would meet the table."""
    pull = scenario.pull
    points = mesh.shank.points
    x = points[:, 0].min() + pull.grasp_x_fraction * np.ptp(points[:, 0])
    y = points[:, 1].max() - pull.grasp_inset_m
    high = points[points[:, 2] >= points[:, 2].max() - pull.grasp_depth_m]
    nearest = high[np.argmin(np.linalg.norm(high[:, :2] - [x, y], axis=1))]
    column = np.linalg.norm(points[:, :2] - nearest[:2], axis=1) < 1e-9
    return np.array([nearest[0], nearest[1], points[column, 2].max() - pull.grasp_depth_m])


def export_mjcf(scene: Scene, path: str | Path) -> Path:
    """Write the scene as MJCF for MuJoCo's own viewer (atomically).

    The mass-spring forces and the binding springs are computed by musclecell, not MuJoCo:
    the file holds the geometry, masses, contacts and constraints only.

    Raises:
        MaterialError: the neo-Hookean continuum, which MJCF cannot express.
    """
    material = scene.scenario.material
    if isinstance(material, ContinuumMaterial) and material.law == "neo_hookean":
        raise MaterialError(None, "material.law",
                            "MuJoCo cannot save its neo-Hookean flexes as MJCF; use 'stvk'")
    xml = scene.spec.to_xml()
    return write_atomic(path, xml)
