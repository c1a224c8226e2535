"""An arm read from a robot description file (MJCF or URDF, as MuJoCo reads both), made to
keep the names :func:`~cell.robots.arms.build_arm` promises, so that it attaches into the cell
as a built arm does: the hinges from the root to the flange renamed ``joint1`` .. ``jointN``,
the file's actuators replaced by one position servo a hinge (sized as
:mod:`cell.robots.servos` sizes a DH arm's, from the chain's lengths), gravity compensation on
every body, and a site ``flange`` where the file's flange site or body is.

Example:
    >>> import tempfile
    >>> from pathlib import Path
    >>> from cell.robots.arms import build_arm
    >>> from cell.robots.dh import KUKA_LWR4
    >>> path = Path(tempfile.mkdtemp()) / "lwr.xml"
    >>> _ = path.write_text(build_arm(KUKA_LWR4).to_xml())
    >>> robot = load_robot_file(path, "flange")
    >>> robot.dof, robot.spec.compile().nu
    (7, 7)
"""

from __future__ import annotations

import itertools
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from cell.errors import InputError
from cell.robots.arms import add_servo
from cell.robots.servos import DEFAULT_SERVO, GRAVITY_M_S2, ServoTuning


@dataclass(frozen=True, eq=False)
class RobotFile:
    """An arm read from a file, renamed and servoed for the cell.

    Attributes:
        spec: the arm, base at the world frame.
        lower_rad, upper_rad: the hinges' limits, rad.
        max_speed_rad_s: the URDF's velocity limits, rad/s, or None (MJCF has none).

    Example:
        >>> RobotFile(mujoco.MjSpec(), (0.0,), (1.0,), None).dof
        1
    """

    spec: mujoco.MjSpec
    lower_rad: tuple[float, ...]
    upper_rad: tuple[float, ...]
    max_speed_rad_s: tuple[float, ...] | None

    @property
    def dof(self) -> int:
        """Number of hinges from the root to the flange."""
        return len(self.lower_rad)


def _chain(spec: mujoco.MjSpec, path: Path, flange: str
           ) -> tuple[mujoco.MjsBody, list[mujoco.MjsBody], tuple | None]:
    """The flange's body, the bodies from the root to it, and the flange site's pose (None for
    a body)."""
    site = spec.site(flange)
    body = site.parent if site is not None else spec.body(flange)
    if body is None or body.name == "world":
        raise InputError(path, "flange", f"no site or body named {flange!r} in the file")
    pose = None if site is None else (np.array(site.pos), np.array(site.quat))
    chain, link = [], body
    while link is not None and link.name != "world":
        chain.append(link)
        link = link.parent
    return body, chain[::-1], pose


def _urdf_limits(path: Path, kind: str) -> dict[str, float]:
    """The URDF's ``<limit>`` attribute ``kind`` (velocity, effort) by joint name."""
    if path.suffix.lower() != ".urdf":
        return {}
    root = ElementTree.parse(path).getroot()
    return {joint.get("name", ""): float(limit.get(kind, "nan"))
            for joint in root.iter("joint") for limit in joint.iter("limit")}


def _levers_m(model: mujoco.MjModel, hinges: list[str]) -> list[float]:
    """Upper bound of the distance from each hinge's axis to the flange: the chain's lengths
    from it, at the file's zero pose, m."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    points = [data.xanchor[model.joint(name).id] for name in hinges]
    points.append(data.site_xpos[model.site("flange").id])
    steps = [float(np.linalg.norm(b - a)) for a, b in itertools.pairwise(points)]
    return [sum(steps[i:]) for i in range(len(hinges))]


def load_robot_file(path: str | Path, flange: str, lower_rad: tuple[float, ...] = (),
                    upper_rad: tuple[float, ...] = (), tuning: ServoTuning = DEFAULT_SERVO
                    ) -> RobotFile:
    """Read the arm in ``path`` up to ``flange`` (a site or a body); ``lower_rad`` and
    ``upper_rad`` replace the file's joint ranges where given.

    Raises:
        InputError: MuJoCo cannot read the file, it measures angles in degrees, it has no such
            flange, a joint on the way is not a hinge or has no range, or the limits given
            do not match its hinges; the field (``file``, ``flange``, ``lower_rad``) named.
    """
    path = Path(path)
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except ValueError as exc:
        raise InputError(path, "file", f"MuJoCo cannot read it: {exc}") from None
    if spec.compiler.degree and path.suffix.lower() != ".urdf":
        raise InputError(path, "file", "angles in degrees: write the arm with "
                         "<compiler angle=\"radian\"/>")
    body, chain, site_pose = _chain(spec, path, flange)
    hinges = [joint for link in chain for joint in link.joints]
    if any(joint.type != mujoco.mjtJoint.mjJNT_HINGE for joint in hinges) or not hinges:
        raise InputError(path, "flange", f"the joints from the root to {flange!r} must be "
                         "hinges, and one at least")
    n = len(hinges)
    for given in (lower_rad, upper_rad):
        if given and len(given) != n:
            raise InputError(path, "lower_rad", f"the file has {n} hinges to the flange; "
                             f"{len(given)} limits given")
    ranges = [tuple(joint.range) for joint in hinges]
    if not (lower_rad and upper_rad) and any(lo >= hi for lo, hi in ranges):
        raise InputError(path, "lower_rad", "a hinge on the way has no range in the file: "
                         "give lower_rad and upper_rad")
    lower = tuple(lower_rad) or tuple(lo for lo, _ in ranges)
    upper = tuple(upper_rad) or tuple(hi for _, hi in ranges)
    speeds, efforts = _urdf_limits(path, "velocity"), _urdf_limits(path, "effort")
    file_speeds = tuple(speeds.get(joint.name, float("nan")) for joint in hinges)
    file_efforts = [efforts.get(joint.name, float("nan")) for joint in hinges]
    for actuator in list(spec.actuators):
        spec.delete(actuator)
    for k, joint in enumerate(hinges):  # twice, so that no new name meets an old one
        joint.name = f"__hinge{k + 1}"
    for k, joint in enumerate(hinges):
        joint.name = f"joint{k + 1}"
    if site_pose is None or flange != "flange":
        position, quaternion = site_pose if site_pose is not None else (np.zeros(3), None)
        body.add_site(name="flange", pos=position,
                      quat=quaternion if quaternion is not None else [1.0, 0.0, 0.0, 0.0])
    for link in spec.bodies:
        if link.name != "world":
            link.gravcomp = 1.0
    model = spec.compile()
    levers = _levers_m(model, [f"joint{k + 1}" for k in range(n)])
    for k, joint in enumerate(hinges):
        reach_m = levers[k] + tuning.tool_reach_m
        kp = n * tuning.load_n * reach_m**2 / tuning.deflection_m
        mass_kg = float(model.body_subtreemass[model.joint(f"joint{k + 1}").bodyid[0]])
        estimate = tuning.torque_margin * GRAVITY_M_S2 * (mass_kg * levers[k]
                                                           + tuning.payload_kg * reach_m)
        torque = file_efforts[k] if np.isfinite(file_efforts[k]) else estimate
        add_servo(spec, joint, (lower[k], upper[k]), kp, torque, tuning)
    return RobotFile(spec, lower, upper,
                     file_speeds if all(np.isfinite(file_speeds)) else None)
