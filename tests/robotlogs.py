"""Small robot logs written by the tests in each form ROS records: ``rostopic echo -p`` dumps, a
ROS 1 bag, ROS 2 bags (SQLite and MCAP storage) and a bare MCAP file, all of the same messages:
one cut (a wrench and a position, each at its own uneven rate), or a whole cell's separation
log (each sensor's wrench, pose and grasp)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: The mapping of these logs, as a mapping file holds it.
MAPPING_TOML = """
[wrench]
topic = "/ft/wrench"
frame = "base"

[position]
topic = "/tool/position"
frame = "base"

[cut]
frame = "base"
edge_direction = [0.0, 1.0, 0.0]
blade_normal = [1.0, 0.0, 0.0]
contact_force_n = 1.0

[block]
size_m = [0.04, 0.2, 0.05]

[blade]
edge_length_m = 0.2
thickness_m = 0.002
edge_angle_deg = 20.0
"""
CELL_MAPPING_TOML = """
[log]
scenario = "scenario.toml"
seed = 0
time_zero_s = 1588763858.0

[channels.knife]
wrench = "/knife/wrench"
pose = "/knife/pose"

[channels.gripper]
wrench = "/gripper/wrench"
pose = "/gripper/pose"
grasp = "/gripper/grasp"

[channels.fixture]
wrench = "/fixture/wrench"
torque = false
"""
WRENCH_TYPE, POSITION_TYPE = "geometry_msgs/msg/WrenchStamped", "geometry_msgs/msg/Vector3Stamped"
POSE_TYPE, GRASP_TYPE = "geometry_msgs/msg/PoseStamped", "std_msgs/msg/Float64"
#: The epoch time of the first message, ns: large, as real stamps are.
START_NS = 1_588_763_858_930_413_213
#: The epoch time of a whole cell's episode start, ns (the mapping's ``time_zero_s``).
CELL_START_NS = 1_588_763_858_000_000_000


@dataclass(frozen=True)
class CutLog:
    """One cut's messages: the wrench's and the position's stamps (ns), values and frames."""

    wrench_ns: np.ndarray
    force_n: np.ndarray
    position_ns: np.ndarray
    position_m: np.ndarray
    frame: str = "base"
    position_frame: str = "base"


def sawing_cut(seed: int = 0) -> CutLog:
    """A sawing cut: the knife sinks 20 mm from 5 mm above a top face at z = 0.23 m while it
    strokes along y; the force rises once the edge is in, plus a sensor offset; the wrench at
    about 250 Hz and the position at about 200 Hz, both uneven."""
    rng = np.random.default_rng(seed)
    wrench_ns = START_NS + np.cumsum(rng.integers(3_000_000, 5_000_000, 600))
    position_ns = START_NS + np.cumsum(rng.integers(4_000_000, 6_000_000, 500))

    def path(time_ns: np.ndarray) -> np.ndarray:
        t = (time_ns - START_NS) * 1e-9
        return np.column_stack([0.5 + 0 * t, -0.2 + 0.015 * np.sin(2 * np.pi * t / 2.0),
                                0.235 - 0.01 * t])

    depth = np.clip(0.23 - path(wrench_ns)[:, 2], 0.0, None)
    force = np.column_stack([0.05 + 0 * depth, -300.0 * depth, 400.0 * depth + 0.4])
    force += rng.normal(0.0, 0.01, force.shape)
    return CutLog(wrench_ns, force, position_ns, path(position_ns))


def write_dumps(log: CutLog, folder: Path) -> Path:
    """``rostopic echo -p`` dumps: ``ft_wrench.txt`` and ``tool_position.txt``."""
    folder.mkdir(parents=True)
    rows = ["%time,field.header.seq,field.header.stamp,field.header.frame_id,"
            "field.wrench.force.x,field.wrench.force.y,field.wrench.force.z,"
            "field.wrench.torque.x,field.wrench.torque.y,field.wrench.torque.z"]
    rows += [f"{t + 150},{i},{t},{log.frame},{_numbers(f)},0.0,0.0,0.0"
             for i, (t, f) in enumerate(zip(log.wrench_ns, log.force_n, strict=True))]
    (folder / "ft_wrench.txt").write_text("\n".join(rows) + "\n")
    rows = ["%time,field.header.seq,field.header.stamp,field.header.frame_id,"
            "field.vector.x,field.vector.y,field.vector.z"]
    rows += [f"{t + 150},{i},{t},{log.position_frame},{_numbers(p)}"
             for i, (t, p) in enumerate(zip(log.position_ns, log.position_m, strict=True))]
    (folder / "tool_position.txt").write_text("\n".join(rows) + "\n")
    return folder


def _numbers(values: np.ndarray) -> str:
    """Values as a dump writes them: every digit of the float."""
    return ",".join(repr(float(v)) for v in values)


def _header(types: dict, time_ns: int, frame: str) -> object:
    stamp = types["builtin_interfaces/msg/Time"](sec=int(time_ns // 10**9),
                                                  nanosec=int(time_ns % 10**9))
    seq = {"seq": 0} if "seq" in types["std_msgs/msg/Header"].__dataclass_fields__ else {}
    return types["std_msgs/msg/Header"](**seq, stamp=stamp, frame_id=frame)


def _wrench(types: dict, time_ns: int, frame: str, force: np.ndarray,
            torque: np.ndarray) -> object:
    vector = types["geometry_msgs/msg/Vector3"]
    return types[WRENCH_TYPE](header=_header(types, time_ns, frame),
                              wrench=types["geometry_msgs/msg/Wrench"](
                                  force=vector(x=force[0], y=force[1], z=force[2]),
                                  torque=vector(x=torque[0], y=torque[1], z=torque[2])))


def _messages(log: CutLog, typestore: object) -> list[tuple[str, str, int, object]]:
    """(topic, type, record time, message) of every message, in time order."""
    types = typestore.types
    vector = types["geometry_msgs/msg/Vector3"]
    found = [("/ft/wrench", WRENCH_TYPE, int(t), _wrench(types, int(t), log.frame, f,
                                                         np.zeros(3)))
             for t, f in zip(log.wrench_ns, log.force_n, strict=True)]
    found += [("/tool/position", POSITION_TYPE, int(t), types[POSITION_TYPE](
        header=_header(types, int(t), log.position_frame), vector=vector(x=p[0], y=p[1],
                                                                         z=p[2])))
        for t, p in zip(log.position_ns, log.position_m, strict=True)]
    return sorted(found, key=lambda item: item[2])


@dataclass(frozen=True)
class CellRobotLog:
    """A whole cell's separation log as a robot would record it (:data:`CELL_MAPPING_TOML`):
    per channel a ``WrenchStamped`` (``/<channel>/wrench``), for the knife and the gripper a
    ``PoseStamped`` (``/<channel>/pose``, the world frame), for the gripper a ``Float64``
    grasp (``/gripper/grasp``); stamps from :data:`CELL_START_NS`, the episode's start."""

    channels: dict

    def messages(self, typestore: object) -> list[tuple[str, str, int, object]]:
        """(topic, type, record time, message) of every message, in time order."""
        types = typestore.types
        point, quaternion = types["geometry_msgs/msg/Point"], types["geometry_msgs/msg/Quaternion"]
        found = []
        for name, channel in self.channels.items():
            times = [CELL_START_NS + round(t * 1e9) for t in channel.time_s]
            torque = channel.torque_nm if channel.torque_nm is not None \
                else np.zeros_like(channel.force_n)
            found += [(f"/{name}/wrench", WRENCH_TYPE, t, _wrench(types, t, name, f, m))
                      for t, f, m in zip(times, channel.force_n, torque, strict=True)]
            if channel.position_m is not None:
                found += [(f"/{name}/pose", POSE_TYPE, t, types[POSE_TYPE](
                    header=_header(types, t, "world"), pose=types["geometry_msgs/msg/Pose"](
                        position=point(x=p[0], y=p[1], z=p[2]),
                        orientation=quaternion(w=q[0], x=q[1], y=q[2], z=q[3]))))
                    for t, p, q in zip(times, channel.position_m, channel.quaternion,
                                       strict=True)]
            if channel.grasp is not None:
                found += [(f"/{name}/grasp", GRASP_TYPE, t, types[GRASP_TYPE](data=float(g)))
                          for t, g in zip(times, channel.grasp, strict=True)]
        return sorted(found, key=lambda item: item[2])


def _all(log: CutLog | CellRobotLog, typestore: object) -> list[tuple[str, str, int, object]]:
    return log.messages(typestore) if isinstance(log, CellRobotLog) else _messages(log, typestore)


def _write_bag(log: CutLog | CellRobotLog, writer: object, typestore: object,
               serialize: object) -> None:
    """Every message of ``log`` into an open bag ``writer``, a connection a topic."""
    connections = {}
    for topic, msgtype, time_ns, message in _all(log, typestore):
        if topic not in connections:
            connections[topic] = writer.add_connection(topic, msgtype, typestore=typestore)
        writer.write(connections[topic], time_ns + 150, serialize(message, msgtype))


def write_ros1_bag(log: CutLog, path: Path) -> Path:
    """A ROS 1 bag."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS1_NOETIC)
    with Writer(path) as writer:
        _write_bag(log, writer, typestore, typestore.serialize_ros1)
    return path


def write_ros2_bag(log: CutLog | CellRobotLog, path: Path, storage: str = "sqlite3") -> Path:
    """A ROS 2 bag's folder, in SQLite (``sqlite3``) or MCAP (``mcap``) storage."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_HUMBLE)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        _write_bag(log, writer, typestore, typestore.serialize_cdr)
    return path


def write_mcap(log: CutLog | CellRobotLog, path: Path) -> Path:
    """A bare MCAP file of ROS 2 messages (schemas ``ros2msg``, messages ``cdr``)."""
    from mcap.writer import Writer
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_HUMBLE)
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="musclecell tests")
        channels = {}
        for topic, msgtype, time_ns, message in _all(log, typestore):
            if topic not in channels:
                text = typestore.generate_msgdef(msgtype, ros_version=2)[0]
                schema = writer.register_schema(msgtype, "ros2msg", text.encode())
                channels[topic] = writer.register_channel(topic, "cdr", schema)
            writer.add_message(channels[topic], log_time=time_ns + 150,
                               data=bytes(typestore.serialize_cdr(message, msgtype)),
                               publish_time=time_ns + 150)
        writer.finish()
    return path
