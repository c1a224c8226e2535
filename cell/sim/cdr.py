"""The ROS 2 messages of a robot program serialised as CDR (little-endian, the encoding ROS 2
and MCAP's ``cdr`` use), written directly: a robot program holds thousands of messages of a
few fixed shapes, and building each as an object for a generic serialiser would cost more than
the episode can spare. ``tests/sim/test_robot_program.py`` checks the bytes against ``rosbags``'.

Each function returns one message's bytes, encapsulation header included; :func:`msgdef`
gives a message type's definition as MCAP's ``ros2msg`` schemas hold it (so that writing
needs no ``rosbags`` type store, whose loading alone costs a short episode's share).
"""

from __future__ import annotations

import functools
import struct
from collections.abc import Sequence

import numpy as np

#: The fields of each message type written, and of the types they hold (ROS 2 Humble's).
_FIELDS = {
    "builtin_interfaces/Time": ("int32 sec", "uint32 nanosec"),
    "builtin_interfaces/Duration": ("int32 sec", "uint32 nanosec"),
    "std_msgs/Header": ("builtin_interfaces/Time stamp", "string frame_id"),
    "sensor_msgs/JointState": ("std_msgs/Header header", "string[] name",
                               "float64[] position", "float64[] velocity", "float64[] effort"),
    "trajectory_msgs/JointTrajectory": ("std_msgs/Header header", "string[] joint_names",
                                        "trajectory_msgs/JointTrajectoryPoint[] points"),
    "trajectory_msgs/JointTrajectoryPoint": (
        "float64[] positions", "float64[] velocities", "float64[] accelerations",
        "float64[] effort", "builtin_interfaces/Duration time_from_start"),
    "geometry_msgs/WrenchStamped": ("std_msgs/Header header", "geometry_msgs/Wrench wrench"),
    "geometry_msgs/Wrench": ("geometry_msgs/Vector3 force", "geometry_msgs/Vector3 torque"),
    "geometry_msgs/Vector3": ("float64 x", "float64 y", "float64 z"),
    "geometry_msgs/Quaternion": ("float64 x", "float64 y", "float64 z", "float64 w"),
    "tf2_msgs/TFMessage": ("geometry_msgs/TransformStamped[] transforms",),
    "geometry_msgs/TransformStamped": ("std_msgs/Header header", "string child_frame_id",
                                       "geometry_msgs/Transform transform"),
    "geometry_msgs/Transform": ("geometry_msgs/Vector3 translation",
                                "geometry_msgs/Quaternion rotation"),
}
#: What separates the definitions of the types a message holds.
_SEPARATOR = "=" * 80


def msgdef(msgtype: str) -> str:
    """The definition of ``msgtype`` (``sensor_msgs/msg/JointState``) in the ``ros2msg``
    form: its fields, then each type it holds, depth first, once.

    Example:
        >>> msgdef("geometry_msgs/msg/Wrench").splitlines()[:2]
        ['geometry_msgs/Vector3 force', 'geometry_msgs/Vector3 torque']
        >>> msgdef("geometry_msgs/msg/Wrench").splitlines()[3]
        'MSG: geometry_msgs/Vector3'
    """
    order: list[str] = []

    def visit(name: str) -> None:
        for field in _FIELDS[name]:
            kind = field.split()[0].removesuffix("[]")
            if kind in _FIELDS and kind not in order:
                order.append(kind)
                visit(kind)

    top = msgtype.replace("/msg/", "/")
    visit(top)
    sections = ["\n".join(_FIELDS[top]) + "\n"]
    sections += [f"{_SEPARATOR}\nMSG: {name}\n" + "\n".join(_FIELDS[name]) + "\n"
                 for name in order]
    return "".join(sections)


#: CDR's encapsulation header: plain CDR, little-endian.
_HEADER = b"\x00\x01\x00\x00"
_U32 = struct.Struct("<I")
_TIME = struct.Struct("<iI")


class CdrWriter:
    """A CDR message under construction: each primitive aligned to its size from the start of
    the payload (after the encapsulation header).

    Example:
        >>> writer = CdrWriter()
        >>> writer.string("world")
        >>> writer.doubles(np.array([1.0]))
        >>> len(writer.bytes())  # header 4; string 4 + 6; padding 2, count 4; one double 8
        28
    """

    def __init__(self) -> None:
        self._buffer = bytearray(_HEADER)

    def _align(self, size: int) -> None:
        self._buffer += bytes(-(len(self._buffer) - len(_HEADER)) % size)

    def time(self, time_ns: int) -> None:
        """A ``builtin_interfaces`` Time or Duration: seconds (int32) and nanoseconds."""
        self._align(4)
        self._buffer += _TIME.pack(time_ns // 10**9, time_ns % 10**9)

    def count(self, n: int) -> None:
        """A sequence's length."""
        self._align(4)
        self._buffer += _U32.pack(n)

    def string(self, text: str) -> None:
        """A string: its length with the terminating NUL, its bytes, the NUL."""
        raw = text.encode() + b"\x00"
        self.count(len(raw))
        self._buffer += raw

    def strings(self, texts: Sequence[str]) -> None:
        """A sequence of strings."""
        self.count(len(texts))
        for text in texts:
            self.string(text)

    def fixed(self, values: np.ndarray) -> None:
        """float64 fields in a row (a Vector3, a Quaternion): no length."""
        self._align(8)
        self._buffer += np.ascontiguousarray(values, dtype="<f8").tobytes()

    def doubles(self, values: np.ndarray) -> None:
        """A float64 sequence: its length, then its values."""
        self.count(len(values))
        if len(values):
            self.fixed(values)

    def header(self, time_ns: int, frame_id: str) -> None:
        """A ``std_msgs/Header``."""
        self.time(time_ns)
        self.string(frame_id)

    def extend(self, payload: bytes) -> None:
        """Payload serialised before from the start of a message, written first here (so
        that its alignment holds)."""
        self._buffer += payload

    def stamp(self, time_ns: int) -> None:
        """Set the time of the message's header (its first field)."""
        _TIME.pack_into(self._buffer, len(_HEADER), time_ns // 10**9, time_ns % 10**9)

    def bytes(self) -> bytes:
        """The message."""
        return bytes(self._buffer)


def joint_state(time_ns: int, names: Sequence[str], position: np.ndarray,
                velocity: np.ndarray, effort: np.ndarray) -> bytes:
    """A ``sensor_msgs/msg/JointState`` (no frame)."""
    writer = CdrWriter()
    writer.extend(_joint_state_start(tuple(names)))
    writer.stamp(time_ns)
    for values in (position, velocity, effort):
        writer.doubles(values)
    return writer.bytes()


@functools.lru_cache(maxsize=32)
def _joint_state_start(names: tuple[str, ...]) -> bytes:
    """A joint state's header (stamped 0) and names: the same in every message of an arm."""
    writer = CdrWriter()
    writer.header(0, "")
    writer.strings(names)
    return writer.bytes()[len(_HEADER):]


def wrench_stamped(time_ns: int, frame_id: str, force: np.ndarray, torque: np.ndarray
                   ) -> bytes:
    """A ``geometry_msgs/msg/WrenchStamped``."""
    writer = CdrWriter()
    writer.header(time_ns, frame_id)
    writer.fixed(np.concatenate([force, torque]))
    return writer.bytes()


def tf_message(time_ns: int, parent: str, children: Sequence[str], positions: np.ndarray,
               quaternions_wxyz: np.ndarray) -> bytes:
    """A ``tf2_msgs/msg/TFMessage``: each child frame's pose (position, (w, x, y, z)
    quaternion) in ``parent``."""
    writer = CdrWriter()
    writer.count(len(children))
    for child, position, quaternion in zip(children, positions, quaternions_wxyz, strict=True):
        writer.header(time_ns, parent)
        writer.string(child)
        writer.fixed(np.concatenate([position, quaternion[[1, 2, 3, 0]]]))
    return writer.bytes()


def joint_trajectory(time_ns: int, frame_id: str, names: Sequence[str],
                     point_times_ns: Sequence[int], positions: np.ndarray,
                     velocities: np.ndarray) -> bytes:
    """A ``trajectory_msgs/msg/JointTrajectory`` whose points have positions and velocities
    (no accelerations, no efforts), each ``point_times_ns`` from its start."""
    writer = CdrWriter()
    writer.header(time_ns, frame_id)
    writer.strings(names)
    writer.count(len(point_times_ns))
    empty = np.zeros(0)
    for k, time_from_start in enumerate(point_times_ns):
        for values in (positions[k], velocities[k], empty, empty):
            writer.doubles(values)
        writer.time(time_from_start)
    return writer.bytes()
