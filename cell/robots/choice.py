"""The arm a scenario chooses for each place of the cell (``[arms.knife]``, ``[arms.gripper]``,
``[arms.camera]``): a built-in arm, a DH table given inline, or a robot description file
(MJCF or URDF) with the flange where the tool mounts.

Whatever its source, a chosen arm becomes a :class:`CellArm`: a spec that keeps the names
:func:`~cell.robots.arms.build_arm` promises (hinges and position servos ``joint1`` ..
``jointN`` from the base to the flange, site ``flange``), its joint limits, its rated speeds
and accelerations, and its home pose.

Example:
    >>> arm = cell_arm(ArmChoice(builtin="kuka_lwr4"))
    >>> arm.name, arm.dof, arm.spec().compile().nu
    ('kuka_lwr4', 7, 7)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from cell.errors import InputError
from cell.robots.arms import build_arm, generic_look
from cell.robots.dh import KUKA_LWR4, VIPER_S1700D, ArmDescription, DHJoint
from cell.robots.robotfile import load_robot_file

#: The built-in arms, by name.
BUILT_IN: dict[str, ArmDescription] = {arm.name: arm for arm in (VIPER_S1700D, KUKA_LWR4)}
_DH_KEYS = ("theta0_rad", "d_m", "a_m", "alpha_rad")
_TABLE_KEYS = ("lower_rad", "upper_rad", "max_speed_rad_s", "max_accel_rad_s2",
               "max_torque_nm", "link_masses_kg", "home_q_rad")


@dataclass(frozen=True)
class ArmChoice:
    """One arm of the cell as a scenario names it: exactly one of ``builtin``, ``file`` or a
    DH table (``theta0_rad``, ``d_m``, ``a_m``, ``alpha_rad``, one entry a joint).

    Attributes:
        builtin: a built-in arm: ``"viper_s1700d"`` or ``"kuka_lwr4"``.
        file: an MJCF (``.xml``) or URDF (``.urdf``) file, path relative to the scenario.
        flange: the file's site or body where the tool mounts (z along the tool axis).
        label: the arm's name in the summary; left out: the built-in's name, the file's stem
            or ``"dh_arm"``.
        theta0_rad, d_m, a_m, alpha_rad: the standard DH table (see :mod:`cell.robots.dh`),
            rad and m.
        lower_rad, upper_rad: joint limits, rad; a file's own ranges where left out.
        max_speed_rad_s: rated joint speeds, rad/s (needed for a DH table or a file).
        max_accel_rad_s2: rated joint accelerations, rad/s^2 (optional: reported against).
        max_torque_nm: joint torque limits, N m (optional: estimated from the masses).
        link_masses_kg: a DH arm's link masses, kg (left out: 2 kg a link).
        home_q_rad: where IK starts, rad (left out: each joint's middle of its range, 0
            where the range holds 0).

    Example:
        >>> ArmChoice(builtin="viper_s1700d").builtin
        'viper_s1700d'
        >>> ArmChoice(builtin="viper_s1700d", file="arm.xml")
        Traceback (most recent call last):
        cell.errors.InputError: builtin: give one of builtin, file or a DH table, not 2
    """

    builtin: str | None = None
    file: str | None = None
    flange: str = "flange"
    label: str | None = None
    theta0_rad: tuple[float, ...] = ()
    d_m: tuple[float, ...] = ()
    a_m: tuple[float, ...] = ()
    alpha_rad: tuple[float, ...] = ()
    lower_rad: tuple[float, ...] = ()
    upper_rad: tuple[float, ...] = ()
    max_speed_rad_s: tuple[float, ...] = ()
    max_accel_rad_s2: tuple[float, ...] = ()
    max_torque_nm: tuple[float, ...] = ()
    link_masses_kg: tuple[float, ...] = ()
    home_q_rad: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        sources = [self.builtin is not None, self.file is not None, bool(self.a_m)]
        if sum(sources) != 1:
            raise InputError(None, "builtin", "give one of builtin, file or a DH table, not "
                             f"{sum(sources)}")
        if self.builtin is not None and self.builtin not in BUILT_IN:
            raise InputError(None, "builtin", f"unknown arm {self.builtin!r} (built-in: "
                             f"{', '.join(sorted(BUILT_IN))})")
        own = {"builtin": _DH_KEYS + _TABLE_KEYS,  # what the arm's source already has
               "file": (*_DH_KEYS, "max_torque_nm", "link_masses_kg")}
        for source, keys in own.items():
            given = [key for key in keys if getattr(self, key)]
            if getattr(self, source) is not None and given:
                raise InputError(None, given[0], f"not for an arm given by {source}: it "
                                 "has its own")
        if self.a_m:
            self._check_lengths(_DH_KEYS + _TABLE_KEYS[:3], len(self.a_m), required=True)
            self._check_lengths(_TABLE_KEYS[3:], len(self.a_m), required=False)
        for key in ("max_speed_rad_s", "max_accel_rad_s2", "max_torque_nm", "link_masses_kg"):
            if any(v <= 0 for v in getattr(self, key)):
                raise InputError(None, key, f"must all be > 0, got {getattr(self, key)}")
        for k, (lo, hi) in enumerate(zip(self.lower_rad, self.upper_rad, strict=False)):
            if not lo < hi:
                raise InputError(None, "lower_rad", f"joint {k + 1}: {lo} is not below {hi}")

    def _check_lengths(self, keys: tuple[str, ...], n: int, required: bool) -> None:
        for key in keys:
            count = len(getattr(self, key))
            if count != n and (required or count):
                raise InputError(None, key, f"expected {n} values (one a joint), got {count}")


@dataclass(frozen=True)
class CellArm:
    """An arm ready for the cell: its spec, limits and home pose, whatever its source.

    Attributes:
        name: the arm's name in the summary.
        source: ``"built-in"``, ``"DH table"`` or the robot file's name.
        lower_rad, upper_rad: joint limits, rad.
        max_speed_rad_s: rated joint speeds, rad/s.
        max_accel_rad_s2: rated joint accelerations, rad/s^2, or None where not given.
        home_q_rad: where IK starts, rad.
        description: the DH arm (built-in or inline), or None for a file.
        file: the robot file, or None.
        flange: the file's site or body where the tool mounts.

    Example:
        >>> cell_arm(ArmChoice(builtin="viper_s1700d")).max_accel_rad_s2 is None
        True
    """

    name: str
    source: str
    lower_rad: tuple[float, ...]
    upper_rad: tuple[float, ...]
    max_speed_rad_s: tuple[float, ...]
    max_accel_rad_s2: tuple[float, ...] | None
    home_q_rad: tuple[float, ...]
    description: ArmDescription | None = None
    file: str | None = None
    flange: str = "flange"

    @property
    def dof(self) -> int:
        """Number of joints."""
        return len(self.lower_rad)

    def spec(self) -> mujoco.MjSpec:
        """The arm's spec, base at the world frame, with the names of
        :func:`~cell.robots.arms.build_arm`."""
        if self.description is not None:
            look = None if self.source == "built-in" else generic_look(self.description)
            return build_arm(self.description, look=look)
        assert self.file is not None
        return load_robot_file(self.file, self.flange, self.lower_rad, self.upper_rad).spec

    def summary(self) -> dict[str, object]:
        """What the episode's summary says of the arm."""
        return {"name": self.name, "source": self.source, "joints": self.dof}


def _home(choice: ArmChoice, lower: tuple[float, ...], upper: tuple[float, ...]
          ) -> tuple[float, ...]:
    if choice.home_q_rad:
        return choice.home_q_rad
    return tuple(0.0 if lo <= 0.0 <= hi else (lo + hi) / 2 for lo, hi in zip(lower, upper,
                                                                           strict=True))


def _dh_arm(choice: ArmChoice) -> ArmDescription:
    n = len(choice.a_m)
    torques = choice.max_torque_nm or (None,) * n
    joints = tuple(DHJoint(*(getattr(choice, key)[k] for key in _DH_KEYS), choice.lower_rad[k],
                           choice.upper_rad[k], choice.max_speed_rad_s[k], torques[k])
                   for k in range(n))
    home = _home(choice, choice.lower_rad, choice.upper_rad)
    masses = choice.link_masses_kg or (2.0,) * n
    return ArmDescription(choice.label or "dh_arm", joints, 4.0, masses, home)


def cell_arm(choice: ArmChoice) -> CellArm:
    """The arm ``choice`` names (a file already resolved to a path that exists).

    Raises:
        InputError: a file that MuJoCo cannot read, no flange of that name, limits of the
            wrong length or a file without the speeds; the field named.
    """
    accel = choice.max_accel_rad_s2 or None
    if choice.builtin is not None or choice.a_m:
        arm = BUILT_IN[choice.builtin] if choice.builtin is not None else _dh_arm(choice)
        joints = arm.joints
        return CellArm(choice.label or arm.name, "built-in" if choice.builtin else "DH table",
                       tuple(j.lower_rad for j in joints), tuple(j.upper_rad for j in joints),
                       tuple(j.max_speed_rad_s for j in joints), accel, arm.home_q_rad, arm)
    assert choice.file is not None
    robot = load_robot_file(choice.file, choice.flange, choice.lower_rad, choice.upper_rad)
    speeds = choice.max_speed_rad_s or robot.max_speed_rad_s
    if speeds is None or len(speeds) != robot.dof:
        raise InputError(None, "max_speed_rad_s", f"the arm in {Path(choice.file).name} has "
                         f"{robot.dof} joints to the flange; give {robot.dof} rated speeds "
                         "(rad/s)")
    for key in ("max_accel_rad_s2", "home_q_rad"):
        if getattr(choice, key) and len(getattr(choice, key)) != robot.dof:
            raise InputError(None, key, f"expected {robot.dof} values, one a joint")
    return CellArm(choice.label or Path(choice.file).stem, Path(choice.file).name,
                   robot.lower_rad, robot.upper_rad, tuple(speeds), accel,
                   _home(choice, robot.lower_rad, robot.upper_rad), None, choice.file,
                   choice.flange)


@dataclass(frozen=True)
class ArmsParams:
    """The scenario's ``[arms]`` table: the arm of each place of the cell.

    Attributes:
        knife: the knife's arm (default: the Viper s1700D).
        gripper: the gripper's arm (default: the Viper s1700D).
        camera: the camera's arm (default: the KUKA LWR4+).

    Example:
        >>> sorted(ArmsParams().cell_arms())
        ['camera_arm', 'knife_arm', 'pull_arm']
    """

    knife: ArmChoice = field(default_factory=lambda: ArmChoice(builtin=VIPER_S1700D.name))
    gripper: ArmChoice = field(default_factory=lambda: ArmChoice(builtin=VIPER_S1700D.name))
    camera: ArmChoice = field(default_factory=lambda: ArmChoice(builtin=KUKA_LWR4.name))

    def cell_arms(self) -> dict[str, CellArm]:
        """Each arm ready for the cell, by its prefix in the scene (``knife_arm``, ...)."""
        return {prefix: cell_arm(getattr(self, place)) for place, prefix in PLACES.items()}


#: The prefix in the scene of the arm of each place (the keys of ``[arms]``).
PLACES = {"knife": "knife_arm", "gripper": "pull_arm", "camera": "camera_arm"}


def near_limit(arm: CellArm, q_rad: np.ndarray) -> int:
    """The joint (0-based) of ``arm`` nearest a limit at ``q_rad``, as a share of its range."""
    lower, upper = np.array(arm.lower_rad), np.array(arm.upper_rad)
    margin = np.minimum(q_rad - lower, upper - q_rad) / (upper - lower)
    return int(np.argmin(margin))


