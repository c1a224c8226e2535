"""The messages of one topic of a ROS 1 bag, a ROS 2 bag or a bare MCAP file, deserialised by
``rosbags`` (the message definitions come from the log itself; a ROS 2 bag that carries none
is read with ROS 2 Humble's standard messages). Needs the ``ros`` extra; imported only by
:func:`cell.robotlog.topics.read_topic`, after it checked that.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from cell.errors import MissingTopicError, RobotLogError

#: MCAP's message encodings that ``rosbags`` deserialises, and the schema encoding of each.
_MCAP_ENCODINGS = {"cdr": "ros2msg", "ros1": "ros1msg"}


def read_messages(source: Path, topic: str) -> tuple[list[int], list[Any]]:
    """The record times (ns since the epoch) and deserialised messages of ``topic`` in the
    bag or MCAP file ``source``; ``topic`` matches with or without its leading slash.

    Raises:
        MissingTopicError: no such topic, naming those there are.
        RobotLogError: a file ``rosbags`` or ``mcap`` cannot read, or an MCAP message encoding
            other than ROS 1's or ROS 2's.
    """
    try:
        if source.suffix == ".mcap":
            return _read_mcap(source, topic)
        return _read_bag(source, topic)
    except (MissingTopicError, RobotLogError):
        raise
    except Exception as exc:  # the readers' own errors, whatever their class
        raise RobotLogError(source, topic, f"cannot read the log: {exc}") from None


def _matches(name: str, topic: str) -> bool:
    return name == topic or name.lstrip("/") == topic.lstrip("/")


def _read_bag(source: Path, topic: str) -> tuple[list[int], list[Any]]:
    with AnyReader([source], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        connections = [c for c in reader.connections if _matches(c.topic, topic)]
        if not connections:
            _missing(source, topic, {c.topic for c in reader.connections})
        times, messages = [], []
        for connection, time_ns, raw in reader.messages(connections=connections):
            times.append(time_ns)
            messages.append(reader.deserialize(raw, connection.msgtype))
    return times, messages


def _read_mcap(source: Path, topic: str) -> tuple[list[int], list[Any]]:
    from mcap.reader import make_reader

    typestore = get_typestore(Stores.EMPTY)
    times, messages = [], []
    with source.open("rb") as stream:
        reader = make_reader(stream)
        topics = {channel.topic for channel in reader.get_summary().channels.values()}
        wanted = [name for name in topics if _matches(name, topic)]
        if not wanted:
            _missing(source, topic, topics)
        for schema, channel, message in reader.iter_messages(topics=wanted):
            encoding = channel.message_encoding
            if _MCAP_ENCODINGS.get(encoding) != getattr(schema, "encoding", None):
                raise RobotLogError(source, topic, f"message encoding {encoding!r} with schema "
                                    f"{getattr(schema, 'encoding', None)!r}: only ROS 1 and "
                                    "ROS 2 messages are read")
            if schema.name not in typestore.fielddefs:
                typestore.register(get_types_from_msg(schema.data.decode(), schema.name))
            decode = (typestore.deserialize_cdr if encoding == "cdr"
                      else typestore.deserialize_ros1)
            times.append(message.log_time)
            messages.append(decode(message.data, schema.name))
    return times, messages


def _missing(source: Path, topic: str, topics: set[str]) -> None:
    raise MissingTopicError(source, topic, f"no such topic; the log has: "
                            f"{', '.join(sorted(topics)) or 'none'}")
