"""One topic of a robot's log, read from any of the forms ROS records: a folder of
``rostopic echo -p`` dumps, a ROS 1 bag, a ROS 2 bag (SQLite or MCAP storage) or a bare MCAP
file. Whatever the form, a topic comes out the same: per message its time and its numeric
fields under the names ``rostopic echo -p`` gives them, less the ``field.`` prefix
(``wrench.force.x``, ``header.frame_id``; arrays as ``position0``, ``position1``, ...).

Bags and MCAP are read with ``rosbags`` and ``mcap`` (the ``ros`` extra); dumps with the
project's own CSV reader, so that a bad cell is named by line and column.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cell.errors import MissingTopicError, RobotLogError
from cell.extras import require
from cell.io import CsvTable, read_csv, read_text

#: The suffixes a ``rostopic echo -p`` dump is found under, for a topic ``forces``.
DUMP_SUFFIXES = (".txt", ".csv")
#: What marks a ROS 2 bag's folder.
ROS2_METADATA = "metadata.yaml"


@dataclass(frozen=True, eq=False)
class TopicSeries:
    """The messages of one topic, in the order they were recorded.

    Attributes:
        source: the dump, bag or MCAP file read.
        topic: the topic's name as the log has it.
        time_ns: (n,) int64, each message's time since the epoch, ns: its ``header.stamp``
            where the message has one that is set, else the time it was recorded (integers,
            so that a log read from a dump and from a bag gives the same times to the ns).
        fields: per numeric field (rostopic's flattened name), its (n,) values.
        frame_ids: the ``header.frame_id`` values the messages carry ("" where none).

    Example:
        >>> series = TopicSeries(Path("log"), "/f", np.array([0, 10**8]),
        ...                      {"vector.x": np.array([1.0, 2.0])}, frozenset({""}))
        >>> series.vector(("vector",)).shape
        Traceback (most recent call last):
        cell.errors.RobotLogError: log, /f: no field vector.y (fields: vector.x)
    """

    source: Path
    topic: str
    time_ns: np.ndarray
    fields: dict[str, np.ndarray]
    frame_ids: frozenset[str]

    def has(self, prefix: str) -> bool:
        """Whether the messages hold a vector ``prefix.x``, ``.y``, ``.z``."""
        return all(f"{prefix}.{axis}" in self.fields for axis in "xyz")

    def vector(self, prefixes: Sequence[str]) -> np.ndarray:
        """(n, 3) the first of the vectors ``prefixes`` (``prefix.x``, ``.y``, ``.z``) that the
        messages hold.

        Raises:
            RobotLogError: none of them, naming the fields there are.
        """
        for prefix in prefixes:
            if self.has(prefix):
                return np.column_stack([self.fields[f"{prefix}.{axis}"] for axis in "xyz"])
        missing = next(f"{prefixes[0]}.{a}" for a in "xyz" if f"{prefixes[0]}.{a}" not in
                       self.fields)
        raise RobotLogError(self.source, self.topic, f"no field {missing} (fields: "
                            f"{', '.join(sorted(self.fields))})")


def read_topic(source: str | Path, topic: str) -> TopicSeries:
    """Topic ``topic`` of the log at ``source``: a folder of ``rostopic echo -p`` dumps (the
    topic is a file's stem there, with or without the leading slash), a ROS 2 bag's folder, a
    ROS 1 ``.bag`` or a ``.mcap`` file.

    Raises:
        MissingTopicError: no such topic, naming those there are.
        RobotLogError: a log that is none of these forms, or a topic with no message.
        MissingExtraError: a bag or MCAP file without the ``ros`` extra.
        CsvError: a dump's malformed cell, by line and column.
    """
    source = Path(source)
    if source.is_dir() and not (source / ROS2_METADATA).exists():
        return _read_dump(source, topic)
    if not source.exists():
        raise RobotLogError(source, None, "no such file or folder")
    if source.suffix not in (".bag", ".mcap") and not source.is_dir():
        raise RobotLogError(source, None, "not a robot log: a folder of rostopic dumps, a ROS "
                            "2 bag's folder, a .bag or a .mcap file")
    require("rosbags", "ros", "reading ROS bags and MCAP files")
    from cell.robotlog.bags import read_messages

    times, messages = read_messages(source, topic)
    rows = [dict(_flattened(message)) for message in messages]
    return _series(source, topic, times, rows)


def _read_dump(folder: Path, topic: str) -> TopicSeries:
    """A topic from the ``rostopic echo -p`` dump ``folder/<topic>.txt`` (or ``.csv``)."""
    stem = topic.strip("/").replace("/", "_")
    path = next((folder / f"{stem}{s}" for s in DUMP_SUFFIXES if (folder / f"{stem}{s}")
                 .is_file()), None)
    if path is None:
        there = sorted(p.stem for p in folder.iterdir() if p.suffix in DUMP_SUFFIXES)
        raise MissingTopicError(folder, topic, f"no dump {stem}.txt or {stem}.csv; the folder "
                                f"has: {', '.join(there) or 'none'}")
    header = read_text(path, "csv").lstrip("\ufeff").partition("\n")[0]
    columns = [c.strip() for c in header.split(",")]
    if "%time" not in columns:
        raise RobotLogError(path, "%time", "not a rostopic echo -p dump: no %time column")
    table = read_csv(path, ["%time"], [c for c in columns if c != "%time"])
    if not table.lines:
        raise RobotLogError(path, topic, "the topic has no message")
    text_columns = [c for c in table.cells if not _is_number(table.cells[c][0])]
    fields = {c.removeprefix("field."): table.numbers(c) for c in table.cells
              if c != "%time" and c not in text_columns}
    fields.pop("header.stamp", None)
    recorded = _integers(table, "%time")
    stamps = (_integers(table, "field.header.stamp") if "field.header.stamp" in table.cells
              else [0])
    time_ns = np.array(stamps if all(s > 0 for s in stamps) else recorded, dtype=np.int64)
    frames = frozenset(table.cells.get("field.header.frame_id", [""]))
    return TopicSeries(path, topic, time_ns, fields, frames)


def _integers(table: CsvTable, column: str) -> list[int]:
    """A column of times in ns as exact integers (a float of epoch nanoseconds would round
    them)."""
    table.numbers(column)  # a bad cell named by line and column
    return [int(cell) if cell.lstrip("-").isdigit() else round(float(cell))
            for cell in table.cells[column]]


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _series(source: Path, topic: str, recorded_ns: list[int], rows: list[dict[str, Any]]
            ) -> TopicSeries:
    """The series of messages already flattened (``rows``), recorded at ``recorded_ns``."""
    if not rows:
        raise RobotLogError(source, topic, "the topic has no message")
    stamps = [row.pop("header.stamp", 0) for row in rows]
    names = [name for name, value in rows[0].items() if not isinstance(value, str)]
    fields = {name: np.array([row.get(name, np.nan) for row in rows], dtype=float)
              for name in names}
    time_ns = np.array(stamps if all(s > 0 for s in stamps) else recorded_ns, dtype=np.int64)
    frames = frozenset(str(row.get("header.frame_id", "")) for row in rows)
    return TopicSeries(source, topic, time_ns, fields, frames)


def _flattened(message: Any, prefix: str = "") -> Iterator[tuple[str, float | int | str]]:
    """``(name, value)`` of every number and string in a deserialised message, named as
    ``rostopic echo -p`` names them; a time (``sec`` and ``nanosec``) as one integer in ns."""
    fields = getattr(message, "__dataclass_fields__", None)
    if fields is None:
        return
    # rosbags keeps the message's type name as a field (``__msgtype__``): not data.
    names = [name for name in fields if not name.startswith("__")]
    if set(names) == {"sec", "nanosec"}:
        yield prefix.rstrip("."), int(message.sec) * 10**9 + int(message.nanosec)
        return
    for name in names:
        value = getattr(message, name)
        if isinstance(value, bool | int | float | np.number):
            yield f"{prefix}{name}", float(value)
        elif isinstance(value, str):
            yield f"{prefix}{name}", value
        elif isinstance(value, np.ndarray | list | tuple):
            for index, item in enumerate(value):
                if isinstance(item, bool | int | float | np.number):
                    yield f"{prefix}{name}{index}", float(item)
        else:
            yield from _flattened(value, f"{prefix}{name}.")
