"""An arm's DH table written out as URDF: links ``base``, ``link1`` .. ``linkN`` and
``flange``, revolute joints ``joint1`` .. ``jointN`` with their limits, rated speeds and torques,
each link's mass as a small sphere of inertia at its frame. For files of an arm the project
builds (tests, exchange with URDF tools); MuJoCo reads it back with
:func:`cell.robots.robotfile.load_robot_file` (``flange`` is a body there: a ``<mujoco>``
element keeps the fixed link unfused).

Example:
    >>> from cell.robots.dh import KUKA_LWR4
    >>> text = arm_urdf(KUKA_LWR4)
    >>> text.count("<joint "), "fusestatic=\\"false\\"" in text
    (8, True)
"""

from __future__ import annotations

import math

import numpy as np

from cell.robots.dh import ArmDescription, dh_transform
from cell.robots.servos import torque_limits_nm

#: Radius of the sphere each link's inertia is taken from, m.
_INERTIA_RADIUS_M = 0.05


def _origin(transform: np.ndarray) -> str:
    """A URDF ``<origin>`` of a 4x4 transform (rpy: fixed-axis x, y, z)."""
    r = transform[:3, :3]
    roll = math.atan2(r[2, 1], r[2, 2])
    pitch = math.atan2(-r[2, 0], math.hypot(r[2, 1], r[2, 2]))
    yaw = math.atan2(r[1, 0], r[0, 0])
    xyz = " ".join(f"{v:.9g}" for v in transform[:3, 3])
    return f'<origin xyz="{xyz}" rpy="{roll:.12g} {pitch:.12g} {yaw:.12g}"/>'


def _link(name: str, mass_kg: float) -> str:
    inertia = 0.4 * mass_kg * _INERTIA_RADIUS_M**2
    return (f'  <link name="{name}"><inertial><origin xyz="0 0 0"/><mass value="{mass_kg}"/>'
            f'<inertia ixx="{inertia}" iyy="{inertia}" izz="{inertia}" ixy="0" ixz="0" '
            'iyz="0"/></inertial></link>')


def arm_urdf(arm: ArmDescription) -> str:
    """URDF text of ``arm`` (angles in rad, lengths in m)."""
    torques = torque_limits_nm(arm)
    lines = ['<?xml version="1.0"?>', f'<robot name="{arm.name}">',
             '  <mujoco><compiler fusestatic="false" discardvisual="false"/></mujoco>',
             _link("base", arm.base_mass_kg)]
    offset, parent = np.eye(4), "base"
    for k, joint in enumerate(arm.joints):
        child = f"link{k + 1}"
        lines.append(_link(child, arm.link_masses_kg[k]))
        lines.append(
            f'  <joint name="joint{k + 1}" type="revolute"><parent link="{parent}"/>'
            f'<child link="{child}"/>{_origin(offset)}<axis xyz="0 0 1"/>'
            f'<limit lower="{joint.lower_rad!r}" upper="{joint.upper_rad!r}" '
            f'velocity="{joint.max_speed_rad_s!r}" effort="{torques[k]!r}"/></joint>')
        offset, parent = dh_transform(joint, 0.0), child
    lines.append(_link("flange", 0.01))
    lines.append(f'  <joint name="flange_mount" type="fixed"><parent link="{parent}"/>'
                 f'<child link="flange"/>{_origin(offset)}</joint>')
    lines.append("</robot>")
    return "\n".join(lines) + "\n"
