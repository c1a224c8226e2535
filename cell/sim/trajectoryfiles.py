"""An episode's robot program (:class:`~cell.sim.trajectory.EpisodeTrajectory`) as a file: a
bare MCAP file of ROS 2 messages (``.mcap``) or one CSV table (``.csv``), by the extension.

MCAP topics (times are the simulation's, from 0 s at the episode's start):

- ``/<arm>/joint_trajectory`` (``trajectory_msgs/msg/JointTrajectory``): the plan, one
  message at 0 s whose points are the commands at the control rate (positions, velocities;
  ``time_from_start`` is each step's end);
- ``/<arm>/joint_states`` (``sensor_msgs/msg/JointState``): the execution, per control step
  (positions rad, velocities rad/s, efforts N m);
- ``/knife/wrench``, ``/gripper/wrench`` (``geometry_msgs/msg/WrenchStamped``): the sensors'
  readings, N and N m, in the sensor site's frame (``header.frame_id``);
- ``/tf`` (``tf2_msgs/msg/TFMessage``): per control step, each arm's tool site
  (``child_frame_id``) in ``world``.

The CSV's columns: ``time_s``, then per arm and joint ``<joint>.planned_q_rad``,
``.planned_qd_rad_s``, ``.q_rad``, ``.qd_rad_s``, ``.effort_nm``, per tool site
``<site>.x_m`` ... ``.qz``, per sensor ``<sensor>.force_x_n`` ... ``.torque_z_nm``.
"""

from __future__ import annotations

import io
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cell.errors import InputError
from cell.extras import require
from cell.outputs import write_together
from cell.sim import cdr
from cell.sim.episode import Episode
from cell.sim.trajectory import EpisodeTrajectory, TrajectorySampler
from cell.sim.trajectorylimits import limits_report

#: The file forms ``--trajectory`` writes, by extension.
TRAJECTORY_SUFFIXES = (".mcap", ".csv")
WORLD_FRAME = "world"
#: What the limits report's file name puts in place of the trajectory's extension.
LIMITS_SUFFIX = ".limits.json"


def limits_path(path: Path) -> Path:
    """Where the limits report of the trajectory file ``path`` goes: beside it.

    Example:
        >>> limits_path(Path("out/program.mcap")).as_posix()
        'out/program.limits.json'
    """
    return path.with_suffix(LIMITS_SUFFIX)


def check_trajectory_path(path: Path) -> None:
    """Before the episode runs: a form :func:`trajectory_bytes` writes, and the ``ros`` extra
    for MCAP.

    Raises:
        InputError: another extension.
        MissingExtraError: MCAP without the ``ros`` extra.
    """
    if path.suffix not in TRAJECTORY_SUFFIXES:
        raise InputError(path, "--trajectory", f"must end in {' or '.join(TRAJECTORY_SUFFIXES)}"
                         f" (MCAP of ROS 2 messages, or CSV), got {path.suffix or 'none'!r}")
    if path.suffix == ".mcap":
        require("mcap", "ros", "writing ROS 2 messages as MCAP")
        import mcap.writer  # noqa: F401  loaded with the command, not after its episode


@dataclass(frozen=True, eq=False)
class ProgramOutput:
    """What ``--trajectory`` writes of an episode that ran, made ready.

    Attributes:
        trajectory: the episode's robot program.
        report: its limits report (:func:`~cell.sim.trajectorylimits.limits_report`).
        content: the trajectory file's bytes.
        cost_s: the wall time it all took: sampling during the episode, then the report and
            the file's content, s.

    Example:
        >>> ProgramOutput.__name__  # made by program_output(episode, sampler, ".mcap")
        'ProgramOutput'
    """

    trajectory: EpisodeTrajectory
    report: dict[str, Any]
    content: bytes
    cost_s: float


def program_output(episode: Episode, sampler: TrajectorySampler, suffix: str
                   ) -> ProgramOutput:
    """The trajectory ``sampler`` took of ``episode`` (which ran), its limits report and the
    file's content for the extension ``suffix``."""
    start = time.perf_counter()
    trajectory = sampler.trajectory()
    report = limits_report(episode.sim.model, episode.sim.data.qpos, trajectory,
                           arms_model=episode.robot_model)
    content = trajectory_bytes(trajectory, suffix)
    cost_s = sampler.elapsed_s + time.perf_counter() - start
    return ProgramOutput(trajectory, report, content, cost_s)


def write_trajectory(path: Path, output: ProgramOutput) -> tuple[Path, Path]:
    """The trajectory at ``path`` and its limits report beside it (:func:`limits_path`),
    written together: both or neither."""
    report_path = limits_path(path)
    write_together({path: output.content,
                    report_path: json.dumps(output.report, indent=2) + "\n"})
    return path, report_path


def trajectory_bytes(trajectory: EpisodeTrajectory, suffix: str) -> bytes:
    """The file's content for the extension ``suffix`` (``.mcap`` or ``.csv``)."""
    return mcap_bytes(trajectory) if suffix == ".mcap" else csv_text(trajectory).encode()


def csv_columns(trajectory: EpisodeTrajectory) -> tuple[list[str], np.ndarray]:
    """The CSV's header and its (n, columns) table."""
    names, blocks = ["time_s"], [trajectory.time_s[:, None]]
    quantities = (("planned_q_rad", "planned_q_rad"), ("planned_qd_rad_s", "planned_qd_rad_s"),
                  ("q_rad", "executed_q_rad"), ("qd_rad_s", "executed_qd_rad_s"),
                  ("effort_nm", "effort_nm"))
    for arm in trajectory.arms.values():
        for k, joint in enumerate(arm.joints):
            for column, field in quantities:
                names.append(f"{joint}.{column}")
                blocks.append(getattr(arm, field)[:, k:k + 1])
    for arm in trajectory.arms.values():
        names += [f"{arm.tool_site}.{axis}" for axis in
                  ("x_m", "y_m", "z_m", "qw", "qx", "qy", "qz")]
        blocks += [arm.tool_position_m, arm.tool_quaternion]
    for sensor in trajectory.force_n:
        names += [f"{sensor}.force_{a}_n" for a in "xyz"]
        names += [f"{sensor}.torque_{a}_nm" for a in "xyz"]
        blocks += [trajectory.force_n[sensor], trajectory.torque_nm[sensor]]
    return names, np.hstack(blocks)


def csv_text(trajectory: EpisodeTrajectory) -> str:
    """The trajectory as one CSV table, a row per control step (numbers to full precision)."""
    names, table = csv_columns(trajectory)
    out = io.StringIO()
    np.savetxt(out, table, delimiter=",", fmt="%.17g", header=",".join(names), comments="")
    return out.getvalue()


def _messages(trajectory: EpisodeTrajectory) -> list[tuple[str, str, int, bytes]]:
    """(topic, message type, time ns, CDR bytes) of every message, in time order, the plan
    first."""
    times_ns = [round(t * 1e9) for t in trajectory.time_s]
    arms = trajectory.arms.values()
    out = [(f"/{prefix}/joint_trajectory", "trajectory_msgs/msg/JointTrajectory", 0,
            cdr.joint_trajectory(0, WORLD_FRAME, arm.joints, times_ns, arm.planned_q_rad,
                                 arm.planned_qd_rad_s))
           for prefix, arm in trajectory.arms.items()]
    sites = [arm.tool_site for arm in arms]
    positions = np.stack([arm.tool_position_m for arm in arms], axis=1)
    quaternions = np.stack([arm.tool_quaternion for arm in arms], axis=1)
    for k, time_ns in enumerate(times_ns):
        out += [(f"/{prefix}/joint_states", "sensor_msgs/msg/JointState", time_ns,
                 cdr.joint_state(time_ns, arm.joints, arm.executed_q_rad[k],
                                 arm.executed_qd_rad_s[k], arm.effort_nm[k]))
                for prefix, arm in trajectory.arms.items()]
        out += [(f"/{sensor}/wrench", "geometry_msgs/msg/WrenchStamped", time_ns,
                 cdr.wrench_stamped(time_ns, frame, trajectory.force_n[sensor][k],
                                    trajectory.torque_nm[sensor][k]))
                for sensor, frame in trajectory.wrench_frames.items()]
        out.append(("/tf", "tf2_msgs/msg/TFMessage", time_ns,
                    cdr.tf_message(time_ns, WORLD_FRAME, sites, positions[k], quaternions[k])))
    return out


def mcap_bytes(trajectory: EpisodeTrajectory) -> bytes:
    """The trajectory as a bare MCAP file of ROS 2 messages (schemas ``ros2msg``, messages
    ``cdr``), in time order."""
    from mcap.writer import Writer

    out = io.BytesIO()
    writer = Writer(out)
    writer.start(profile="ros2", library="musclecell")
    channels: dict[str, int] = {}
    for topic, msgtype, time_ns, data in _messages(trajectory):
        if topic not in channels:
            schema = writer.register_schema(msgtype, "ros2msg", cdr.msgdef(msgtype).encode())
            channels[topic] = writer.register_channel(topic, "cdr", schema)
        writer.add_message(channels[topic], log_time=time_ns, publish_time=time_ns, data=data)
    writer.finish()
    return out.getvalue()
