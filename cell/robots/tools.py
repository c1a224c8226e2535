"""End effectors: the knife with its force/torque sensor, the two-finger gripper, the camera.

Each builder returns a small :class:`mujoco.MjSpec` whose root body sits on a robot flange
(the flange z axis is the tool axis, pointing away from the robot). The scene attaches it
with ``spec.attach(tool, site=flange, prefix=...)``, so the local names below gain a prefix.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from cell.collision import JAWS, ROBOTS
from cell.config import require_non_negative, require_positive
from cell.errors import InputError
from cell.robots.cad import ConvexParts, add_part, decompose

#: The blade's contact impedance (MuJoCo's solimp: d0, dmax, width m, midpoint, power).
#: MuJoCo averages a contact's solimp over its two sides, so the blade's contacts with the
#: flesh (the muscles' 0.9 to 0.95) resolve with 0.5 to 0.55: half the correction per step.
#: The constraint solver sees a flesh vertex as its mass alone, while within an implicit
#: step its springs make it many times heavier in the paper's Fig. 10 material; there the
#: blade's fully resolved contacts flung vertices off the blade, their springs threw them
#: back, and episodes ran away (tissue above 20 m/s).
BLADE_SOLIMP = (0.1, 0.15, 0.001, 0.5, 2.0)


@dataclass(frozen=True)
class KnifeParams:
    """A boning knife on a 6-axis force/torque sensor, as in the paper's cell.

    The blade lies in the tool's x-z plane: its length runs along the tool axis z, its cutting
    edge faces tool +x and its thickness is along tool y. Lengths in m, masses in kg.
    ``handle_mesh``: a CAD handle (STL or OBJ, m, z along the tool axis from the sensor's top
    at z = 0, the edge's side +x) instead of the capsule: shown whole, colliding as its
    convex pieces (:mod:`cell.robots.cad`); the blade starts ``handle_length_m`` up.

    Example:
        >>> spec = build_knife(KnifeParams(blade_length_m=0.2))
    """

    blade_length_m: float = 0.20
    blade_width_m: float = 0.025
    blade_thickness_m: float = 0.001
    handle_length_m: float = 0.12
    handle_radius_m: float = 0.016
    sensor_height_m: float = 0.03
    sensor_radius_m: float = 0.04
    sensor_mass_kg: float = 0.25
    handle_mass_kg: float = 0.15
    blade_mass_kg: float = 0.04
    handle_mesh: str = ""

    def __post_init__(self) -> None:
        require_positive(self, *(name for name, value in vars(self).items()
                                 if isinstance(value, float)))

    @property
    def tip_offset_m(self) -> float:
        """Distance from the flange to the blade tip along the tool axis, m."""
        return self.sensor_height_m + self.handle_length_m + self.blade_length_m

    @property
    def blade_half_size_m(self) -> np.ndarray:
        """Half extents of the blade box in its own frame (x width, y thickness, z length), m."""
        return 0.5 * np.array([self.blade_width_m, self.blade_thickness_m, self.blade_length_m])


@dataclass(frozen=True)
class GripperParams:
    """A parallel two-finger gripper on a force/torque sensor.

    The fingers slide along tool y; ``max_opening_m`` is the widest jaw gap.

    Example:
        >>> spec = build_gripper(GripperParams(max_opening_m=0.1))
    """

    palm_size_m: tuple[float, float, float] = (0.06, 0.14, 0.04)
    finger_length_m: float = 0.09
    finger_width_m: float = 0.05
    finger_thickness_m: float = 0.012
    max_opening_m: float = 0.10
    finger_force_n: float = 60.0
    sensor_height_m: float = 0.03
    palm_mass_kg: float = 0.8
    finger_mass_kg: float = 0.1

    def __post_init__(self) -> None:
        require_positive(self, "finger_length_m", "finger_width_m", "finger_thickness_m",
                         "max_opening_m", "finger_force_n")

    @property
    def grasp_offset_m(self) -> float:
        """Distance from the flange to the middle of the jaws along the tool axis, m."""
        return self.sensor_height_m + self.palm_size_m[2] + 0.8 * self.finger_length_m


@dataclass(frozen=True)
class CameraParams:
    """A depth camera (structured light or time of flight) on the camera arm's flange.

    Example:
        >>> spec = build_camera(CameraParams(fovy_deg=45.0))
    """

    fovy_deg: float = 45.0
    width_px: int = 320
    height_px: int = 240
    housing_size_m: tuple[float, float, float] = (0.14, 0.04, 0.03)
    mass_kg: float = 0.4

    def __post_init__(self) -> None:
        if not 1.0 < self.fovy_deg < 179.0:
            raise InputError(None, "fovy_deg", f"must be in (1, 179), got {self.fovy_deg}")
        if self.width_px < 8 or self.height_px < 8:
            raise InputError(None, "width_px", "image must be at least 8 x 8 pixels")


@dataclass(frozen=True)
class FixtureParams:
    """What holds the round besides its pinned base: an optional CAD clamp.

    ``clamp_mesh``: a clamp (STL or OBJ, m) standing on the table against the round's outer
    wall: its frame goes to the middle of the wall's foot, y toward the meat, so the mesh's
    face toward the meat lies on y = 0 and its base on z = 0. It is shown whole and collides
    (with the tissue and the tools) as its convex pieces (:mod:`cell.robots.cad`);
    ``clearance_m`` keeps it off the wall at rest.

    Example:
        >>> FixtureParams(clamp_mesh="clamp.stl").clearance_m
        0.002
    """

    clamp_mesh: str = ""
    clearance_m: float = 0.002

    def __post_init__(self) -> None:
        require_non_negative(self, "clearance_m")


def _add_ft_sensor(spec: mujoco.MjSpec, body: mujoco.MjsBody) -> None:
    """A 6-axis F/T sensor between flange and tool: it reads what the flange exerts on the tool."""
    body.add_site(name="ft", size=[0.005, 0, 0])
    spec.add_sensor(
        name="force", type=mujoco.mjtSensor.mjSENS_FORCE,
        objtype=mujoco.mjtObj.mjOBJ_SITE, objname="ft",
    )
    spec.add_sensor(
        name="torque", type=mujoco.mjtSensor.mjSENS_TORQUE,
        objtype=mujoco.mjtObj.mjOBJ_SITE, objname="ft",
    )


def build_knife(params: KnifeParams = KnifeParams(),
                handle: ConvexParts | None = None) -> mujoco.MjSpec:
    """Knife spec: root body ``knife`` with geoms ``sensor``, ``handle`` (with
    ``handle_mesh``, its pieces ``handle_0``, ... too: ``handle`` if given, else decomposed
    here), ``blade``; sites ``ft`` (sensor frame), ``tip`` (blade tip) and ``blade`` (blade
    centre); sensors ``force`` and ``torque`` (N, N m, in the sensor frame, acting on the
    knife)."""
    spec = mujoco.MjSpec()
    knife = spec.worldbody.add_body(name="knife")
    _add_ft_sensor(spec, knife)
    h = params.sensor_height_m
    knife.add_geom(
        name="sensor", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[params.sensor_radius_m, h / 2, 0], pos=[0, 0, h / 2],
        mass=params.sensor_mass_kg, rgba=[0.2, 0.2, 0.22, 1],
        contype=ROBOTS.contype, conaffinity=ROBOTS.conaffinity,
    )
    if params.handle_mesh:
        handle = handle or decompose(params.handle_mesh, "knife.handle_mesh")
        add_part(spec, knife, "handle", handle, mass_kg=params.handle_mass_kg, pos=(0, 0, h))
    else:
        knife.add_geom(
            name="handle", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            size=[params.handle_radius_m, params.handle_length_m / 2 - params.handle_radius_m,
                  0],
            pos=[0, 0, h + params.handle_length_m / 2],
            mass=params.handle_mass_kg, rgba=[0.1, 0.1, 0.1, 1],
            contype=ROBOTS.contype, conaffinity=ROBOTS.conaffinity,
        )
    blade_centre = h + params.handle_length_m + params.blade_length_m / 2
    knife.add_geom(
        name="blade", type=mujoco.mjtGeom.mjGEOM_BOX, size=params.blade_half_size_m,
        pos=[0, 0, blade_centre], mass=params.blade_mass_kg, rgba=[0.85, 0.87, 0.9, 1],
        contype=ROBOTS.contype, conaffinity=ROBOTS.conaffinity, friction=[0.3, 0.005, 0.0001],
        solimp=BLADE_SOLIMP,
    )
    knife.add_site(name="blade", pos=[0, 0, blade_centre], size=[0.002, 0, 0])
    knife.add_site(name="tip", pos=[0, 0, params.tip_offset_m], size=[0.003, 0, 0],
                   rgba=[1, 0, 0, 1])
    return spec


def build_gripper(params: GripperParams = GripperParams()) -> mujoco.MjSpec:
    """Gripper spec: root body ``gripper`` (palm), finger bodies ``finger_left``/``finger_right``
    on slide joints driven by position actuators of the same names (ctrl = each finger's
    distance from the centre line, m), site ``grasp`` between the jaws, sensors ``force`` and
    ``torque`` at site ``ft``."""
    spec = mujoco.MjSpec()
    palm = spec.worldbody.add_body(name="gripper")
    _add_ft_sensor(spec, palm)
    sx, sy, sz = params.palm_size_m
    z_palm = params.sensor_height_m + sz / 2
    palm.add_geom(
        name="sensor", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[0.04, params.sensor_height_m / 2, 0], pos=[0, 0, params.sensor_height_m / 2],
        mass=0.25, rgba=[0.2, 0.2, 0.22, 1], contype=ROBOTS.contype, conaffinity=ROBOTS.conaffinity,
    )
    palm.add_geom(
        name="palm", type=mujoco.mjtGeom.mjGEOM_BOX, size=[sx / 2, sy / 2, sz / 2],
        pos=[0, 0, z_palm], mass=params.palm_mass_kg, rgba=[0.3, 0.32, 0.35, 1],
        contype=ROBOTS.contype, conaffinity=ROBOTS.conaffinity,
    )
    finger_z = params.sensor_height_m + sz + params.finger_length_m / 2
    half_open = params.max_opening_m / 2
    for side, sign in (("left", 1.0), ("right", -1.0)):
        finger = palm.add_body(name=f"finger_{side}", pos=[0, 0, 0])
        finger.add_joint(
            name=f"finger_{side}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, sign, 0],
            range=[0.0, half_open], damping=20.0, armature=0.05,
        )
        finger.add_geom(
            name=f"jaw_{side}", type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[params.finger_width_m / 2, params.finger_thickness_m / 2,
                  params.finger_length_m / 2],
            pos=[0, sign * params.finger_thickness_m / 2, finger_z],
            mass=params.finger_mass_kg, rgba=[0.55, 0.57, 0.6, 1],
            contype=JAWS.contype, conaffinity=JAWS.conaffinity,
        )
        spec.add_actuator(
            name=f"finger_{side}", target=f"finger_{side}",
            trntype=mujoco.mjtTrn.mjTRN_JOINT, gaintype=mujoco.mjtGain.mjGAIN_FIXED,
            biastype=mujoco.mjtBias.mjBIAS_AFFINE, gainprm=[2000.0] + [0] * 9,
            biasprm=[0, -2000.0, -50.0] + [0] * 7, ctrlrange=[0.0, half_open],
            forcerange=[-params.finger_force_n, params.finger_force_n],
            ctrllimited=True, forcelimited=True,
        )
    palm.add_site(name="grasp", pos=[0, 0, params.grasp_offset_m], size=[0.004, 0, 0],
                  rgba=[0, 1, 0, 1])
    return spec


def build_camera(params: CameraParams = CameraParams()) -> mujoco.MjSpec:
    """Camera spec: root body ``camera`` with a housing, a MuJoCo camera ``camera`` whose
    optical axis is the flange's +z (MuJoCo cameras look along their own -z), and a site
    ``optical`` on that axis."""
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="camera")
    sx, sy, sz = params.housing_size_m
    body.add_geom(
        name="housing", type=mujoco.mjtGeom.mjGEOM_BOX, size=[sx / 2, sy / 2, sz / 2],
        pos=[0, 0, sz / 2], mass=params.mass_kg, rgba=[0.15, 0.15, 0.15, 1],
        contype=ROBOTS.contype, conaffinity=ROBOTS.conaffinity,
    )
    body.add_camera(name="camera", pos=[0, 0, sz + 0.002], quat=[0, 1, 0, 0],
                    fovy=params.fovy_deg, resolution=[params.width_px, params.height_px])
    # mink cannot aim a camera frame, so IK aims this site, whose +z is the optical axis.
    body.add_site(name="optical", pos=[0, 0, sz + 0.002], size=[0.004, 0, 0])
    return spec
