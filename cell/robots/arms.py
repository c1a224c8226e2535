"""Build an arm from its DH table as a :class:`mujoco.MjSpec`, ready to attach into the cell.

The spec's names are a contract with the rest of musclecell (an attach prefix such as
``knife_arm/`` is prepended to all of them):

* body ``base``: the DH base frame, z up; bodies ``link1`` .. ``linkN``, body ``link{i}`` sits at
  DH frame i-1 and turns with joint i about its local z;
* hinge joints ``joint1`` .. ``jointN`` (the DH variable q, limited to the DH range);
* one position actuator per joint, also named ``joint{i}`` (actuators are their own namespace),
  control range = joint range, torque-limited, with gravity compensation routed through it;
* site ``flange`` on ``linkN`` at DH frame N, z along the tool axis, where tools are attached.

Example:
    >>> import mujoco
    >>> from cell.robots.dh import VIPER_S1700D
    >>> model = build_arm(VIPER_S1700D).compile()
    >>> model.nu, model.site("flange").bodyid[0] == model.body("link6").id
    (6, np.True_)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from cell.errors import InputError
from cell.robots.dh import KUKA_LWR4, VIPER_S1700D, ArmDescription, dh_transform
from cell.robots.servos import (
    DEFAULT_SERVO,
    ServoTuning,
    link_length_m,
    servo_stiffness_nm_per_rad,
    torque_limits_nm,
)

__all__ = [
    "KUKA_LWR4_LOOK",
    "LOOKS",
    "VIPER_S1700D_LOOK",
    "ArmLook",
    "add_servo",
    "build_arm",
    "generic_look",
]

# Segments shorter than this are not drawn: a DH offset of zero means the two axes meet.
_MIN_SEGMENT_M = 1e-6
_RGBA = tuple[float, float, float, float]


@dataclass(frozen=True)
class ArmLook:
    """Primitive shapes that make a DH chain look like its arm.

    Link i is drawn as capsules along its DH offsets (d along its own axis, then a along the
    common normal) and a cylinder housing the next joint at its far end; the last link ends in
    a flange disk instead.

    Attributes:
        segment_radius_m: capsule radius of each link, in m.
        housing_radius_m: radius of the housing of joint i+1 on link i, and of the flange disk
            for the last link, in m.
        base_radius_m: radius of the base column, in m.
        base_height_m: height of the base column, in m; link 1 starts above it.
        shell_rgba: colour of the link shells.
        housing_rgba: colour of the joint housings, the base and the flange.

    Example:
        >>> len(VIPER_S1700D_LOOK.segment_radius_m)
        6
    """

    segment_radius_m: tuple[float, ...]
    housing_radius_m: tuple[float, ...]
    base_radius_m: float
    base_height_m: float
    shell_rgba: _RGBA
    housing_rgba: _RGBA

    def size_m(self, link: int) -> float:
        """Largest radius of link ``link`` (0 is the base), in m."""
        if link == 0:
            return self.base_radius_m
        return max(self.segment_radius_m[link - 1], self.housing_radius_m[link - 1])


VIPER_S1700D_LOOK = ArmLook(
    segment_radius_m=(0.15, 0.09, 0.09, 0.065, 0.05, 0.04),
    housing_radius_m=(0.12, 0.11, 0.085, 0.07, 0.055, 0.045),
    base_radius_m=0.2,
    base_height_m=0.25,
    shell_rgba=(0.93, 0.93, 0.91, 1.0),
    housing_rgba=(0.45, 0.46, 0.48, 1.0),
)
"""White shells, grey housings, sized after the Viper s1700D's drawings."""

KUKA_LWR4_LOOK = ArmLook(
    segment_radius_m=(0.06, 0.06, 0.06, 0.06, 0.055, 0.05, 0.04),
    housing_radius_m=(0.065, 0.065, 0.065, 0.065, 0.06, 0.055, 0.04),
    base_radius_m=0.08,
    base_height_m=0.11,
    shell_rgba=(1.0, 0.45, 0.05, 1.0),
    housing_rgba=(0.4, 0.4, 0.42, 1.0),
)
"""Orange shells, grey joint rings, sized after the LWR4+."""

LOOKS: dict[str, ArmLook] = {
    VIPER_S1700D.name: VIPER_S1700D_LOOK,
    KUKA_LWR4.name: KUKA_LWR4_LOOK,
}
"""Look of each known arm, by :attr:`ArmDescription.name`."""


def _quat(rotation: np.ndarray) -> np.ndarray:
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, rotation.reshape(9))
    return quat


@dataclass(frozen=True)
class _Shape:
    """One primitive before its mass is known: MuJoCo type, size, pose in the link frame."""

    name: str
    kind: mujoco.mjtGeom
    size: tuple[float, ...]
    pos: np.ndarray
    quat: np.ndarray
    rgba: _RGBA
    volume_m3: float


def _capsule(name: str, start: np.ndarray, end: np.ndarray, radius: float, rgba: _RGBA) -> _Shape:
    axis = end - start
    length = float(np.linalg.norm(axis))
    # Orientation from the z axis onto the segment, so the shape is fixed by pos/quat alone.
    quat = np.empty(4)
    mujoco.mju_quatZ2Vec(quat, axis / length)
    volume = math.pi * radius**2 * (length + 4.0 * radius / 3.0)
    return _Shape(
        name,
        mujoco.mjtGeom.mjGEOM_CAPSULE,
        (radius, length / 2),
        (start + end) / 2,
        quat,
        rgba,
        volume,
    )


def _cylinder(
    name: str, center: np.ndarray, rotation: np.ndarray, radius: float, half: float, rgba: _RGBA
) -> _Shape:
    volume = 2.0 * math.pi * radius**2 * half
    return _Shape(
        name, mujoco.mjtGeom.mjGEOM_CYLINDER, (radius, half), center, _quat(rotation), rgba, volume
    )


def _link_shapes(arm: ArmDescription, look: ArmLook, i: int) -> list[_Shape]:
    """Shapes of link ``i`` (0-based) in its body frame, DH frame i rotated by q_i."""
    joint = arm.joints[i]
    end = dh_transform(joint, 0.0)
    corner = np.array([0.0, 0.0, joint.d_m])
    tip = end[:3, 3]
    radius = look.segment_radius_m[i]
    housing = look.housing_radius_m[i]
    name = f"link{i + 1}"
    shapes = []
    # Link 1 rises out of the base column rather than from the floor.
    start = np.array([0.0, 0.0, look.base_height_m if i == 0 else 0.0])
    if joint.d_m - start[2] > _MIN_SEGMENT_M:
        shapes.append(_capsule(f"{name}_column", start, corner, radius, look.shell_rgba))
    if abs(joint.a_m) > _MIN_SEGMENT_M:
        shapes.append(_capsule(f"{name}_arm", corner, tip, radius, look.shell_rgba))
    if i < arm.dof - 1:
        shapes.append(
            _cylinder(f"{name}_housing", tip, end[:3, :3], housing, housing, look.housing_rgba)
        )
    else:
        # The disk ends flush with the flange, so a tool attached there touches, not overlaps.
        half = 0.2 * housing
        shapes.append(
            _cylinder(
                f"{name}_flange",
                tip - half * end[:3, 2],
                end[:3, :3],
                housing,
                half,
                look.housing_rgba,
            )
        )
    return shapes


def _excluded_pairs(arm: ArmDescription, look: ArmLook) -> list[tuple[int, int]]:
    """Link pairs whose contacts are off (0 is the base).

    Neighbours always overlap at their joint. Links i and i+2 are excluded too when link i+1 is
    shorter than their radii: primitive shapes cannot show the clearance the real joint keeps
    between them (a spherical wrist, the LWR's knuckles).
    """
    pairs = [(i, i + 1) for i in range(arm.dof)]
    for i in range(arm.dof - 1):
        gap_m = link_length_m(arm.joints[i])
        if gap_m < look.size_m(i) + look.size_m(i + 2):
            pairs.append((i, i + 2))
    return pairs


def _body_name(link: int) -> str:
    return "base" if link == 0 else f"link{link}"


def _checked_look(arm: ArmDescription, look: ArmLook | None) -> ArmLook:
    """``look``, or the arm's own from ``LOOKS`` when None, checked against the arm's links."""
    if look is None:
        if arm.name not in LOOKS:
            raise InputError(None, "look", f"no look known for arm {arm.name!r}; pass one")
        look = LOOKS[arm.name]
    if len(look.segment_radius_m) != arm.dof or len(look.housing_radius_m) != arm.dof:
        raise InputError(None, "look", f"{arm.name} has {arm.dof} links; the look has not")
    return look


def _add_base(spec: mujoco.MjSpec, arm: ArmDescription, look: ArmLook) -> mujoco.MjsBody:
    """The fixed base: a column on the world frame's origin, carrying the base mass."""
    base = spec.worldbody.add_body(name="base")
    half_height = look.base_height_m / 2
    base.add_geom(
        name="base_column",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[look.base_radius_m, half_height, 0.0],
        pos=[0.0, 0.0, half_height],
        mass=arm.base_mass_kg,
        rgba=look.housing_rgba,
    )
    return base


def add_servo(spec: mujoco.MjSpec, hinge: mujoco.MjsJoint, range_rad: tuple[float, float],
              kp: float, torque_nm: float, tuning: ServoTuning) -> None:
    """Limit ``hinge`` to ``range_rad`` and drive it by a position servo of stiffness ``kp``
    (N m/rad) named as the hinge, torque-limited to ``torque_nm`` (N m) together with the
    gravity compensation routed through it; damping and armature as :func:`build_arm` says."""
    inertia_time_s2 = (tuning.timestep_s / tuning.omega_timestep) ** 2
    hinge.range = list(range_rad)
    hinge.limited = mujoco.mjtLimited.mjLIMITED_TRUE
    hinge.damping = [kp * tuning.damping_time_s, 0.0, 0.0]
    hinge.armature = kp * inertia_time_s2
    hinge.actgravcomp = True
    # Servo and gravity compensation come from one motor: clamp their sum.
    hinge.actfrclimited = mujoco.mjtLimited.mjLIMITED_TRUE
    hinge.actfrcrange = [-torque_nm, torque_nm]
    actuator = spec.add_actuator(
        name=hinge.name,
        target=hinge.name,
        trntype=mujoco.mjtTrn.mjTRN_JOINT,
        ctrllimited=mujoco.mjtLimited.mjLIMITED_TRUE,
        ctrlrange=list(range_rad),
        forcelimited=mujoco.mjtLimited.mjLIMITED_TRUE,
        forcerange=[-torque_nm, torque_nm],
    )
    actuator.set_to_position(kp=kp, dampratio=tuning.dampratio)


def generic_look(arm: ArmDescription) -> ArmLook:
    """A plain look for an arm the cell has no look of: grey shells 5 cm thick at the base,
    thinning to 3.5 cm at the flange."""
    radii = tuple(float(r) for r in np.linspace(0.05, 0.035, arm.dof))
    return ArmLook(
        segment_radius_m=radii,
        housing_radius_m=tuple(1.1 * r for r in radii),
        base_radius_m=0.07,
        base_height_m=0.05,
        shell_rgba=(0.7, 0.72, 0.75, 1.0),
        housing_rgba=(0.3, 0.32, 0.35, 1.0),
    )


@dataclass(frozen=True)
class _Servo:
    """One joint's servo: stiffness kp (N m/rad), torque limit (N m) and the tuning."""

    kp_nm_per_rad: float
    torque_nm: float
    tuning: ServoTuning


def _add_link(spec: mujoco.MjSpec, parent: mujoco.MjsBody, offset: np.ndarray,
              arm: ArmDescription, look: ArmLook, i: int, servo: _Servo) -> mujoco.MjsBody:
    """Link i + 1 at ``offset`` (4x4, the previous joint's DH transform) in ``parent``: its
    hinge, its shapes carrying the link's mass by volume, and its position servo."""
    joint, kp, torque, tuning = arm.joints[i], servo.kp_nm_per_rad, servo.torque_nm, servo.tuning
    body = parent.add_body(
        name=f"link{i + 1}", pos=offset[:3, 3], quat=_quat(offset[:3, :3]), gravcomp=1.0
    )
    hinge = body.add_joint(
        name=f"joint{i + 1}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0.0, 0.0, 1.0]
    )
    shapes = _link_shapes(arm, look, i)
    total_volume = sum(s.volume_m3 for s in shapes)
    for shape in shapes:
        body.add_geom(
            name=shape.name,
            type=shape.kind,
            size=[*shape.size, 0.0],
            pos=shape.pos,
            quat=shape.quat,
            mass=arm.link_masses_kg[i] * shape.volume_m3 / total_volume,
            rgba=shape.rgba,
        )
    add_servo(spec, hinge, (joint.lower_rad, joint.upper_rad), kp, torque, tuning)
    return body


def build_arm(
    arm: ArmDescription,
    *,
    stiffness_nm_per_rad: float | None = None,
    tuning: ServoTuning = DEFAULT_SERVO,
    look: ArmLook | None = None,
) -> mujoco.MjSpec:
    """Build ``arm`` as a spec whose base frame is the spec's world frame.

    Every link carries ``gravcomp = 1`` and every joint ``actgravcomp``, so the servos hold the
    arm against gravity exactly, within their torque limits; the position error left is that
    of loads the arm was not built with (tools, contacts). The armature of joint i is
    kp_i (timestep / omega_timestep)^2, which bounds the servo frequencies so that explicit
    stiffness (``implicitfast``) is stable at ``tuning.timestep_s``; ``discrete`` is stable
    at any step. The spec authors no ``option`` so that it merges into a scene's without
    conflict; angles are in radians.

    Args:
        arm: DH table, masses and home pose.
        stiffness_nm_per_rad: kp of every joint servo, in N m/rad; None sizes each joint's kp
            with :func:`~cell.robots.servos.servo_stiffness_nm_per_rad`.
        tuning: servo sizing; see :class:`~cell.robots.servos.ServoTuning`.
        look: shapes and colours; None takes ``LOOKS[arm.name]``.

    Returns:
        A spec that compiles alone and can be attached under a prefix.

    Raises:
        InputError: no look is known for the arm, or the look has the wrong number of links.

    Example:
        >>> spec = build_arm(KUKA_LWR4)
        >>> parent = mujoco.MjSpec()
        >>> frame = parent.worldbody.add_frame(pos=[1.0, 0.0, 0.0])
        >>> _ = parent.attach(spec, frame=frame, prefix="camera_arm/")
        >>> parent.compile().actuator("camera_arm/joint7").trnid[0] > 0
        np.True_
    """
    look = _checked_look(arm, look)
    if stiffness_nm_per_rad is None:
        kp = servo_stiffness_nm_per_rad(arm, tuning)
    else:
        kp = (stiffness_nm_per_rad,) * arm.dof
    torque = torque_limits_nm(arm, tuning)

    spec = mujoco.MjSpec()
    spec.modelname = arm.name
    spec.compiler.degree = False
    parent = _add_base(spec, arm, look)
    offset = np.eye(4)
    for i, joint in enumerate(arm.joints):
        parent = _add_link(spec, parent, offset, arm, look, i, _Servo(kp[i], torque[i], tuning))
        offset = dh_transform(joint, 0.0)
    parent.add_site(name="flange", pos=offset[:3, 3], quat=_quat(offset[:3, :3]))
    for a, b in _excluded_pairs(arm, look):
        spec.add_exclude(bodyname1=_body_name(a), bodyname2=_body_name(b))
    return spec
