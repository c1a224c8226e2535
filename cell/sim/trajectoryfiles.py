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
        require("rosbags", "ros", "writing ROS 2 messages as MCAP")


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
    report = limits_report(episode.sim.model, episode.sim.data.qpos, trajectory)
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


def _stamp(types: Any, time_s: float) -> Any:
    ns = round(time_s * 1e9)
    return types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)


def _messages(trajectory: EpisodeTrajectory, types: Any
              ) -> list[tuple[str, str, float, Any]]:
    """(topic, message type, time s, message) of every message, plan first."""
    header = types["std_msgs/msg/Header"]
    vector, duration = types["geometry_msgs/msg/Vector3"], types["builtin_interfaces/msg/Duration"]
    point = types["trajectory_msgs/msg/JointTrajectoryPoint"]
    out = []
    for prefix, arm in trajectory.arms.items():
        points = [point(positions=arm.planned_q_rad[k], velocities=arm.planned_qd_rad_s[k],
                        accelerations=np.zeros(0), effort=np.zeros(0),
                        time_from_start=duration(sec=int(t), nanosec=round((t % 1) * 1e9)))
                  for k, t in enumerate(trajectory.time_s)]
        out.append((f"/{prefix}/joint_trajectory", "trajectory_msgs/msg/JointTrajectory", 0.0,
                    types["trajectory_msgs/msg/JointTrajectory"](
                        header=header(stamp=_stamp(types, 0.0), frame_id=WORLD_FRAME),
                        joint_names=list(arm.joints), points=points)))
    for k, t in enumerate(trajectory.time_s):
        stamp = _stamp(types, t)
        for prefix, arm in trajectory.arms.items():
            out.append((f"/{prefix}/joint_states", "sensor_msgs/msg/JointState", t,
                        types["sensor_msgs/msg/JointState"](
                            header=header(stamp=stamp, frame_id=""), name=list(arm.joints),
                            position=arm.executed_q_rad[k], velocity=arm.executed_qd_rad_s[k],
                            effort=arm.effort_nm[k])))
        for sensor, frame in trajectory.wrench_frames.items():
            force, torque = trajectory.force_n[sensor][k], trajectory.torque_nm[sensor][k]
            out.append((f"/{sensor}/wrench", "geometry_msgs/msg/WrenchStamped", t,
                        types["geometry_msgs/msg/WrenchStamped"](
                            header=header(stamp=stamp, frame_id=frame),
                            wrench=types["geometry_msgs/msg/Wrench"](
                                force=vector(*force), torque=vector(*torque)))))
        out.append(("/tf", "tf2_msgs/msg/TFMessage", t, types["tf2_msgs/msg/TFMessage"](
            transforms=[_transform(types, header(stamp=stamp, frame_id=WORLD_FRAME),
                                   arm.tool_site, arm.tool_position_m[k],
                                   arm.tool_quaternion[k])
                        for arm in trajectory.arms.values()])))
    return out


def _transform(types: Any, header: Any, child: str, position_m: np.ndarray,
               quaternion: np.ndarray) -> Any:
    w, x, y, z = (float(c) for c in quaternion)
    return types["geometry_msgs/msg/TransformStamped"](
        header=header, child_frame_id=child, transform=types["geometry_msgs/msg/Transform"](
            translation=types["geometry_msgs/msg/Vector3"](*(float(c) for c in position_m)),
            rotation=types["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)))


def mcap_bytes(trajectory: EpisodeTrajectory) -> bytes:
    """The trajectory as a bare MCAP file of ROS 2 messages (schemas ``ros2msg``, messages
    ``cdr``), in time order."""
    from mcap.writer import Writer
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_HUMBLE)
    out = io.BytesIO()
    writer = Writer(out)
    writer.start(profile="ros2", library="musclecell")
    channels: dict[str, int] = {}
    for topic, msgtype, time_s, message in _messages(trajectory, typestore.types):
        if topic not in channels:
            text = typestore.generate_msgdef(msgtype, ros_version=2)[0]
            schema = writer.register_schema(msgtype, "ros2msg", text.encode())
            channels[topic] = writer.register_channel(topic, "cdr", schema)
        ns = round(time_s * 1e9)
        writer.add_message(channels[topic], log_time=ns, publish_time=ns,
                           data=bytes(typestore.serialize_cdr(message, msgtype)))
    writer.finish()
    return out.getvalue()
