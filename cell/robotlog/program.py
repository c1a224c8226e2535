"""A robot program read back: the joint commands a program file holds, as ``musclecell run
--trajectory`` writes it (docs/robot-programs.md): per arm, a ``trajectory_msgs/JointTrajectory``
on ``/<arm>/joint_trajectory`` of an MCAP file or ROS 2 bag, or the ``<joint>.planned_q_rad``
columns of the CSV. :func:`cell.sim.programreplay.play_program` plays them.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from cell.errors import RobotLogError
from cell.extras import require
from cell.io import read_csv

#: The CSV's column suffix of a joint's commands.
COMMAND_COLUMN = ".planned_q_rad"


def read_program(source: str | Path, arms: Sequence[str]) -> dict[str, np.ndarray]:
    """Each joint's commands (joint name -> (n,) rad, one a control step) of the arms named
    ``arms`` (``knife_arm``, ...) in the program file ``source`` (``.mcap``, a ROS 2 bag's
    folder, or ``.csv``).

    Raises:
        MissingTopicError: an arm's trajectory topic that the file does not have.
        RobotLogError: an arm with no joint, a trajectory of no point, a file of another form.
        MissingExtraError: an MCAP file or bag without the ``ros`` extra.

    Example:
        >>> import tempfile
        >>> folder = Path(tempfile.mkdtemp())
        >>> _ = (folder / "p.csv").write_text(
        ...     "time_s,a/joint1.planned_q_rad,a/joint1.q_rad\\n0.01,0.5,0.49\\n0.02,0.6,0.58\\n")
        >>> read_program(folder / "p.csv", ["a"])
        {'a/joint1': array([0.5, 0.6])}
    """
    source = Path(source)
    if source.suffix == ".csv":
        return _from_csv(source, arms)
    require("rosbags", "ros", "reading ROS bags and MCAP files")
    from cell.robotlog.bags import read_messages

    commands: dict[str, np.ndarray] = {}
    for arm in arms:
        topic = f"/{arm}/joint_trajectory"
        _, messages = read_messages(source, topic)
        points = messages[-1].points if messages else []
        if not points:
            raise RobotLogError(source, topic, "a trajectory of no point")
        positions = np.array([point.positions for point in points], dtype=float)
        for k, name in enumerate(messages[-1].joint_names):
            commands[name] = positions[:, k]
    return commands


def _from_csv(source: Path, arms: Sequence[str]) -> dict[str, np.ndarray]:
    header = read_csv(source, ["time_s"]).header
    columns = {arm: [c for c in header if c.startswith(f"{arm}/") and c.endswith(COMMAND_COLUMN)]
               for arm in arms}
    for arm, found in columns.items():
        if not found:
            raise RobotLogError(source, arm, f"no column <joint>{COMMAND_COLUMN} of the arm "
                                f"{arm!r}")
    wanted = [c for found in columns.values() for c in found]
    table = read_csv(source, ["time_s", *wanted])
    return {column.removesuffix(COMMAND_COLUMN): table.numbers(column) for column in wanted}
