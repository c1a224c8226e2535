"""Arms of other makers for the tests, built from their published DH tables by the project's
own builder and written out as robot files (third-party robot files are never committed).

The UR5e: Universal Robots' published DH parameters and joint ranges (+-360 deg) and the
rated speed of pi rad/s for every joint. A seven-axis arm: the LWR4+'s DH table the project
has, written as MJCF.
"""

from __future__ import annotations

import math
from pathlib import Path

from cell.robots.arms import build_arm, generic_look
from cell.robots.choice import ArmChoice, cell_arm
from cell.robots.dh import KUKA_LWR4
from cell.robots.urdf import arm_urdf

_PI = math.pi

UR5E = ArmChoice(
    label="ur5e",
    theta0_rad=(0.0,) * 6,
    d_m=(0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996),
    a_m=(0.0, -0.425, -0.3922, 0.0, 0.0, 0.0),
    alpha_rad=(_PI / 2, 0.0, 0.0, _PI / 2, -_PI / 2, 0.0),
    lower_rad=(-2 * _PI,) * 6,
    upper_rad=(2 * _PI,) * 6,
    max_speed_rad_s=(_PI,) * 6,
    link_masses_kg=(3.761, 8.058, 2.846, 1.37, 1.3, 0.365),
    home_q_rad=(0.0, -1.2, 1.6, -1.8, -1.57, 0.0),
)
"""The UR5e as a DH table (link masses: UR's published dynamics parameters)."""

#: Where the UR5e and the seven-axis gripper arm stand in the test scenarios: beside the table,
#: on pedestals at its height (their reach, 0.85 m and 0.8 m, is half the Vipers').
UR5E_BASE = (0.0, -0.5, 0.6, 90.0)
SEVEN_AXIS_BASE = (0.0, 0.75, 0.45, -90.0)


def write_ur5e(folder: Path, kind: str) -> Path:
    """The UR5e written as ``kind`` (``"xml"``: MJCF, ``"urdf"``) into ``folder``."""
    arm = cell_arm(UR5E).description
    assert arm is not None
    path = folder / f"ur5e.{kind}"
    text = build_arm(arm, look=generic_look(arm)).to_xml() if kind == "xml" else arm_urdf(arm)
    path.write_text(text)
    return path


def write_seven_axis(folder: Path) -> Path:
    """The LWR4+'s DH arm written as MJCF into ``folder``."""
    path = folder / "seven_axis.xml"
    path.write_text(build_arm(KUKA_LWR4).to_xml())
    return path


def arms_scenario(folder: Path, knife: str, extra: str = "") -> Path:
    """A scenario beside the robot files: the default episode with the UR5e from ``knife``
    (a file name in ``folder``) and the seven-axis MJCF arm as the gripper's arm, both on
    their pedestals; ``extra`` appended (more TOML)."""
    speeds = ", ".join(["3.141592653589793"] * 6)
    path = folder / f"arms_{Path(knife).suffix[1:]}.toml"
    path.write_text(f"""[scenario]
name = "ur5e_{Path(knife).suffix[1:]}"

[layout]
knife_arm_base = {list(UR5E_BASE)}
pull_arm_base = {list(SEVEN_AXIS_BASE)}

[arms.knife]
file = "{knife}"
flange = "flange"
max_speed_rad_s = [{speeds}]
home_q_rad = {list(UR5E.home_q_rad)}

[arms.gripper]
file = "seven_axis.xml"
max_speed_rad_s = {[j.max_speed_rad_s for j in KUKA_LWR4.joints]}
home_q_rad = {list(KUKA_LWR4.home_q_rad)}
{extra}""")
    return path
