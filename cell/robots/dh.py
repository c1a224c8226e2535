"""Standard Denavit-Hartenberg kinematics of the cell's arms.

Each joint moves its frame by ``Rz(theta0 + q) Tz(d) Tx(a) Rx(alpha)``, the standard (distal) DH
convention, in metres and radians. Frame 0 is the arm's base frame (z up, along the first joint
axis); frame N is the flange frame, its z axis the tool axis pointing out of the flange.

Example:
    >>> from cell.robots.dh import VIPER_S1700D, dh_transform
    >>> first = dh_transform(VIPER_S1700D.joints[0], VIPER_S1700D.home_q_rad[0])
    >>> first.shape, float(first[2, 3])
    ((4, 4), 0.505)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cell.errors import InputError

__all__ = [
    "KUKA_LWR4",
    "VIPER_S1700D",
    "ArmDescription",
    "DHJoint",
    "dh_transform",
]


@dataclass(frozen=True)
class DHJoint:
    """One revolute joint in standard DH form.

    Attributes:
        theta0_rad: constant offset added to the joint angle, in rad.
        d_m: offset along the previous z axis, in m.
        a_m: length along the new x axis, in m.
        alpha_rad: twist about the new x axis, in rad.
        lower_rad: lower joint limit, in rad (in the convention where q = 0 is ``theta0_rad``).
        upper_rad: upper joint limit, in rad.
        max_speed_rad_s: rated joint speed, in rad/s.
        max_torque_nm: rated joint torque, in N m, or None where the maker does not publish it.

    Example:
        >>> DHJoint(0.0, 0.3105, 0.0, math.pi / 2, -2.97, 2.97, 1.92, 176.0).d_m
        0.3105
    """

    theta0_rad: float
    d_m: float
    a_m: float
    alpha_rad: float
    lower_rad: float
    upper_rad: float
    max_speed_rad_s: float
    max_torque_nm: float | None


@dataclass(frozen=True)
class ArmDescription:
    """A serial arm: its DH joints, link masses and a home pose.

    Attributes:
        name: short identifier of the arm model.
        joints: DH joints from the base to the flange.
        base_mass_kg: mass of the fixed base, in kg.
        link_masses_kg: mass of each moving link, in kg; link i is moved by joint i.
        home_q_rad: a start configuration inside the limits, in rad.

    Example:
        >>> VIPER_S1700D.dof
        6
    """

    name: str
    joints: tuple[DHJoint, ...]
    base_mass_kg: float
    link_masses_kg: tuple[float, ...]
    home_q_rad: tuple[float, ...]

    def __post_init__(self) -> None:
        n = len(self.joints)
        if len(self.link_masses_kg) != n or len(self.home_q_rad) != n:
            raise InputError(
                None,
                f"{self.name}.link_masses_kg/home_q_rad",
                f"{n} joints need {n} link masses and {n} home angles, got "
                f"{len(self.link_masses_kg)} and {len(self.home_q_rad)}",
            )

    @property
    def dof(self) -> int:
        """Number of joints."""
        return len(self.joints)


def dh_transform(joint: DHJoint, q: float) -> np.ndarray:
    """Homogeneous transform from frame i-1 to frame i for joint angle ``q``.

    Args:
        joint: the DH parameters of joint i.
        q: joint angle, in rad.

    Returns:
        4x4 matrix ``Rz(theta0 + q) Tz(d) Tx(a) Rx(alpha)``, translation in m.

    Example:
        >>> float(dh_transform(KUKA_LWR4.joints[0], 0.0)[2, 3])
        0.3105
    """
    theta = joint.theta0_rad + q
    ct, st = math.cos(theta), math.sin(theta)
    ca, sa = math.cos(joint.alpha_rad), math.sin(joint.alpha_rad)
    return np.array(
        [
            [ct, -st * ca, st * sa, joint.a_m * ct],
            [st, ct * ca, -ct * sa, joint.a_m * st],
            [0.0, sa, ca, joint.d_m],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def _deg(*angles: float) -> tuple[float, ...]:
    return tuple(math.radians(a) for a in angles)


def _viper_joint(
    theta0: float, d: float, a: float, alpha: float, lo: float, hi: float, speed: float
) -> DHJoint:
    return DHJoint(
        theta0, d, a, alpha, math.radians(lo), math.radians(hi), math.radians(speed), None
    )


def _lwr_joint(d: float, alpha: float, limit: float, speed: float, torque: float) -> DHJoint:
    return DHJoint(
        0.0, d, 0.0, alpha, -math.radians(limit), math.radians(limit), math.radians(speed), torque
    )


_PI = math.pi

VIPER_S1700D = ArmDescription(
    name="viper_s1700d",
    joints=(
        _viper_joint(0.0, 0.505, 0.150, -_PI / 2, -180.0, 180.0, 170.0),
        _viper_joint(-_PI / 2, 0.0, 0.760, 0.0, -110.0, 155.0, 170.0),
        _viper_joint(0.0, 0.0, 0.140, -_PI / 2, -150.0, 80.0, 175.0),
        _viper_joint(0.0, 0.795, 0.0, _PI / 2, -200.0, 200.0, 355.0),
        _viper_joint(0.0, 0.0, 0.0, -_PI / 2, -140.0, 140.0, 345.0),
        _viper_joint(_PI, 0.105, 0.0, 0.0, -360.0, 360.0, 525.0),
    ),
    # Adept publishes no base mass; 40 kg is a plausible cast foot for a 1.7 m, 20 kg arm. The
    # base never moves, so the value only enters the total weight of the cell.
    base_mass_kg=40.0,
    link_masses_kg=(121.9, 42.0, 37.0, 11.5, 2.6, 0.27),
    # Away from the J3 and J5 limits, where IK starts well.
    home_q_rad=_deg(0.0, 25.0, -2.0, 0.0, 67.0, 18.0),
)
"""Adept Viper s1700D: 6 axes, 1.717 m reach to the wrist centre, 20 kg payload."""

KUKA_LWR4 = ArmDescription(
    name="kuka_lwr4",
    joints=(
        _lwr_joint(0.3105, _PI / 2, 170.0, 110.0, 176.0),
        _lwr_joint(0.0, -_PI / 2, 120.0, 110.0, 176.0),
        _lwr_joint(0.400, -_PI / 2, 170.0, 128.0, 100.0),
        _lwr_joint(0.0, _PI / 2, 120.0, 128.0, 100.0),
        _lwr_joint(0.390, _PI / 2, 170.0, 204.0, 100.0),
        _lwr_joint(0.0, -_PI / 2, 120.0, 184.0, 38.0),
        _lwr_joint(0.078, 0.0, 170.0, 184.0, 38.0),
    ),
    base_mass_kg=1.21,
    link_masses_kg=(2.30, 2.30, 2.30, 2.30, 1.60, 1.49, 0.11),
    # Flange 0.58 m in front of the base (+x), pointing straight down, 45 deg or more from every
    # limit.
    home_q_rad=_deg(0.0, -30.0, 0.0, 75.0, 0.0, -75.0, 0.0),
)
"""KUKA LWR4+: 7 axes, 7 kg payload, joint torque limits published."""
