"""A whole cell's robot log (a ROS 1 or 2 bag, an MCAP file or rostopic dumps: the knife's and
the gripper's wrench and pose, the grasp, the fixture's dynamometer) turned into a separation
log (docs/log-format.md) that ``musclecell replay`` and ``diagnose-logs`` read.

Each channel's samples are its wrench's messages; the sensor's pose is sampled at those times
(positions linearly, orientations by normalised linear interpolation; as logged where the
times agree), the grasp held from its last message. Times count from the mapping's
``time_zero_s``, or from the earliest message of the mapped topics.

Usage::

    folder = import_cell_logs(read_cell_mapping("cell.toml"), ["run-3.mcap"], "logs/run-3")
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from cell.errors import RobotLogError
from cell.folders import write_folder
from cell.measure.logs import CHANNELS, Channel, channel_rows, log_toml, read_log
from cell.outputs import write_rows
from cell.robotlog.cellmapping import CellMapping, ChannelTopics
from cell.robotlog.cutlog import FORCE_FIELDS
from cell.robotlog.topics import TopicSeries, read_topic

TORQUE_FIELDS = ("wrench.torque", "torque")
POSE_FIELDS = (("pose.position", "pose.orientation"), ("pose.pose.position",
                                                      "pose.pose.orientation"),
               ("transform.translation", "transform.rotation"))
GRASP_FIELD = "data"


def _topics(source: Path, mapping: CellMapping) -> dict[str, dict[str, TopicSeries]]:
    """Per channel, its topics read (``wrench``, and ``pose`` and ``grasp`` where mapped)."""
    read = {}
    for name, topics in mapping.channels.items():
        read[name] = {kind: read_topic(source, topic) for kind, topic in
                      (("wrench", topics.wrench), ("pose", topics.pose),
                       ("grasp", topics.grasp)) if topic}
    return read


def _pose(series: TopicSeries) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) positions and (n, 4) quaternions w x y z of a pose or transform topic."""
    for position, orientation in POSE_FIELDS:
        if series.has(position) and series.has(orientation) \
                and f"{orientation}.w" in series.fields:
            quaternion = np.column_stack([series.fields[f"{orientation}.{axis}"]
                                          for axis in "wxyz"])
            return series.vector((position,)), quaternion
    raise RobotLogError(series.source, series.topic, "not a pose: no pose.position and "
                        "pose.orientation, nor transform.translation and transform.rotation "
                        f"(fields: {', '.join(sorted(series.fields))})")


def _at(times_ns: np.ndarray, series_ns: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``values`` (rows at ``series_ns``) linearly at ``times_ns``; as they are where the
    times agree."""
    if np.array_equal(times_ns, series_ns):
        return values
    offsets = (series_ns - series_ns[0]).astype(float)
    at = (times_ns - series_ns[0]).astype(float)
    return np.column_stack([np.interp(at, offsets, values[:, k])
                            for k in range(values.shape[1])])


def _channel(name: str, topics: ChannelTopics, read: dict[str, TopicSeries],
             zero_ns: int) -> Channel:
    wrench = read["wrench"]
    times = wrench.time_ns
    if np.any(np.diff(times) <= 0):
        raise RobotLogError(wrench.source, wrench.topic, "its times do not increase")
    force = topics.sign * wrench.vector(FORCE_FIELDS)
    torque = topics.sign * wrench.vector(TORQUE_FIELDS) if topics.torque else None
    position = quaternion = grasp = None
    if "pose" in read:
        pose = read["pose"]
        if times[0] < pose.time_ns[0] or times[-1] > pose.time_ns[-1]:
            raise RobotLogError(pose.source, pose.topic, f"its messages do not span the "
                                f"{name} wrench's ({wrench.topic})")
        logged_position, logged_quaternion = _pose(pose)
        position = _at(times, pose.time_ns, logged_position)
        quaternion = _at(times, pose.time_ns, logged_quaternion)
        if quaternion is not logged_quaternion:
            quaternion = quaternion / np.linalg.norm(quaternion, axis=1, keepdims=True)
    if "grasp" in read:
        held = read["grasp"]
        if GRASP_FIELD not in held.fields:
            raise RobotLogError(held.source, held.topic, f"no field {GRASP_FIELD}: a std_msgs "
                                "Float64, Int or Bool topic")
        last = np.searchsorted(held.time_ns, times, side="right") - 1
        grasp = np.where(last >= 0, held.fields[GRASP_FIELD][last.clip(0)] > 0.5, 0)
    return Channel((times - zero_ns) * 1e-9, force, torque, position, quaternion,
                   None if grasp is None else grasp.astype(int))


def cell_log_channels(source: str | Path, mapping: CellMapping) -> dict[str, Channel]:
    """The channels of the separation log that the robot log at ``source`` records.

    Raises:
        MissingTopicError: a topic the mapping names is not in the log.
        RobotLogError: a topic without the fields needed, times that do not increase, a pose
            that does not span its wrench, a start after the first message.
    """
    source = Path(source)
    read = _topics(source, mapping)
    first_ns = min(int(series.time_ns[0]) for topics in read.values()
                   for series in topics.values())
    zero_ns = first_ns if mapping.log.time_zero_s is None \
        else round(mapping.log.time_zero_s * 1e9)
    if zero_ns > first_ns:
        raise RobotLogError(source, "log.time_zero_s", "is after the log's first message")
    return {name: _channel(name, mapping.channels[name], read[name], zero_ns)
            for name in CHANNELS}


def import_cell_logs(mapping: CellMapping, sources: Sequence[str | Path],
                     out: str | Path) -> Path:
    """Write the separation log of each robot log of ``sources`` (one: into ``out``; several:
    a folder each in ``out``, named after the log's file or folder), whole or not at all, each
    read back as any log is; returns ``out``."""
    names = [Path(source).stem if Path(source).is_file() else Path(source).name
             for source in sources]
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise RobotLogError(None, "sources", f"two logs named {twice[0]!r}: each becomes a "
                            "log named after its file or folder")
    logs = [cell_log_channels(source, mapping) for source in sources]
    base = mapping.path.parent if mapping.path is not None else Path.cwd()
    scenario = (base / mapping.log.scenario).resolve()

    def fill(folder: Path) -> None:
        for name, channels in zip(names, logs, strict=True):
            target = folder / name if len(logs) > 1 else folder
            target.mkdir(exist_ok=True)
            for stem, channel in channels.items():
                write_rows(target / f"{stem}.csv", *channel_rows(channel))
            # The scenario's path is written from where the log will be read, not from here.
            final = Path(out) / name if len(logs) > 1 else Path(out)
            relative = Path(os.path.relpath(scenario, final.resolve())).as_posix()
            (target / "log.toml").write_text(log_toml(
                name, relative, mapping.log.seed, mapping.sensors, mapping.cut_windows_s,
                mapping.outcome))
        for name in names:
            read_log(folder / name if len(logs) > 1 else folder)

    return write_folder(out, fill)
