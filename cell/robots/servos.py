"""How the arms' joint servos are sized: stiffness from the deflection allowed at the tool,
torque limits from the published ones or from the static load of the outstretched arm.

Example:
    >>> from cell.robots.dh import VIPER_S1700D
    >>> len(servo_stiffness_nm_per_rad(VIPER_S1700D)), DEFAULT_SERVO.load_n
    (6, 20.0)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from cell.robots.dh import ArmDescription, DHJoint

GRAVITY_M_S2 = 9.81


@dataclass(frozen=True)
class ServoTuning:
    """How :func:`build_arm` sizes the joint servos, and the load it sizes them for.

    Attributes:
        load_n: force at the tool the servos must hold, in N.
        deflection_m: flange deflection allowed under ``load_n``, in m; shared equally between
            the joints, so the bound holds whatever the load's direction and the arm's pose.
        tool_reach_m: distance from the flange to where a tool carries its load, in m.
        timestep_s: time step the servos must be stable at with explicit stiffness
            (``implicitfast``), in s.
        omega_timestep: bound on (servo natural frequency x ``timestep_s``); explicit springs
            diverge at 2, and accuracy suffers well before.
        dampratio: damping ratio of each position servo (MuJoCo computes kv from it at qpos0).
        damping_time_s: joint viscous damping as kp x this time, in s; a drive friction that
            also keeps the ``Euler`` integrator stable, at a lag of q' x this time, in rad.
        payload_kg: payload used to estimate torque limits the maker does not publish, in kg.
        torque_margin: estimated torque limit / static torque of the outstretched arm with
            the payload at ``tool_reach_m``.

    Example:
        >>> ServoTuning(deflection_m=0.5e-3).load_n
        20.0
    """

    load_n: float = 20.0
    deflection_m: float = 1e-3
    tool_reach_m: float = 0.2
    timestep_s: float = 0.002
    omega_timestep: float = 0.5
    dampratio: float = 1.0
    damping_time_s: float = 0.001
    payload_kg: float = 20.0
    torque_margin: float = 1.5


DEFAULT_SERVO = ServoTuning()
"""The servo sizing the cell uses: 1 mm at the flange under 20 N at 0.2 m from it, 2 ms steps."""


def link_length_m(joint: DHJoint) -> float:
    """The length of a link's DH offsets together (a along the common normal, d along the
    axis), m."""
    return math.hypot(joint.a_m, joint.d_m)


def _lever_arms_m(arm: ArmDescription, tool_reach_m: float) -> list[list[float]]:
    """Upper bounds of the distance from each joint axis to each link's far end and the tool.

    Row i (0-based joint) has N + 1 entries: links 1..N, then the tool point. The d offset of
    joint i runs along its own axis, so only its a offset counts.
    """
    n = arm.dof
    levers = []
    for i in range(n):
        row = [0.0] * (n + 1)
        reach = abs(arm.joints[i].a_m)
        for k in range(i, n):
            if k > i:
                reach += link_length_m(arm.joints[k])
            row[k] = reach
        row[n] = reach + tool_reach_m
        levers.append(row)
    return levers


def servo_stiffness_nm_per_rad(
    arm: ArmDescription, tuning: ServoTuning = DEFAULT_SERVO
) -> tuple[float, ...]:
    """Position gain kp of each joint so the flange yields at most ``tuning.deflection_m``.

    A force F at lever r from joint i turns it by F r / kp and moves the tool by F r^2 / kp; with
    the deflection shared equally by the N joints, kp_i = N F r_i^2 / deflection.

    Args:
        arm: the arm.
        tuning: load, allowed deflection and tool reach.

    Returns:
        kp per joint, in N m/rad.

    Example:
        >>> from cell.robots.dh import VIPER_S1700D
        >>> kp = servo_stiffness_nm_per_rad(VIPER_S1700D)
        >>> kp[0] > kp[5]
        True
    """
    levers = _lever_arms_m(arm, tuning.tool_reach_m)
    return tuple(arm.dof * tuning.load_n * row[-1] ** 2 / tuning.deflection_m for row in levers)


def torque_limits_nm(arm: ArmDescription, tuning: ServoTuning = DEFAULT_SERVO) -> tuple[float, ...]:
    """Torque limit of each joint: the published one, or an estimate where there is none.

    The estimate is ``tuning.torque_margin`` times the gravity torque about the joint, taken as
    horizontal, of the links beyond it stretched out, each with its mass at its far end, plus
    ``tuning.payload_kg`` at ``tuning.tool_reach_m`` beyond the flange: an upper bound of the
    static load, with headroom for acceleration.

    Args:
        arm: the arm.
        tuning: payload, tool reach and margin of the estimate.

    Returns:
        torque limit per joint, in N m.

    Example:
        >>> from cell.robots.dh import KUKA_LWR4
        >>> torque_limits_nm(KUKA_LWR4)[0]
        176.0
    """
    levers = _lever_arms_m(arm, tuning.tool_reach_m)
    limits = []
    for i, joint in enumerate(arm.joints):
        if joint.max_torque_nm is not None:
            limits.append(joint.max_torque_nm)
            continue
        row = levers[i]
        moment_kg_m = sum(m * r for m, r in zip(arm.link_masses_kg, row, strict=False))
        moment_kg_m += tuning.payload_kg * row[-1]
        limits.append(tuning.torque_margin * GRAVITY_M_S2 * moment_kg_m)
    return tuple(limits)
