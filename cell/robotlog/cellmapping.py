"""The mapping file of a whole cell's robot log (docs/robot-logs.md, "A whole cell's log"):
which topics are each sensor's wrench, pose and grasp, where the episode's time starts, which
scenario the cell ran, and the log's sensors, phases and outcome as a separation log holds
them (docs/log-format.md).

Example:
    >>> mapping = cell_mapping_from_toml({
    ...     "log": {"scenario": "default.toml"},
    ...     "channels": {"knife": {"wrench": "/knife/wrench", "pose": "/knife/pose"},
    ...                  "gripper": {"wrench": "/gripper/wrench", "pose": "/gripper/pose",
    ...                              "grasp": "/gripper/grasp"},
    ...                  "fixture": {"wrench": "/fixture/wrench"}}})
    >>> mapping.channels["gripper"].grasp, mapping.log.seed
    ('/gripper/grasp', None)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cell.config import from_table, read_toml
from cell.errors import MappingError
from cell.measure.logs import CHANNELS

#: The tables of a whole cell's mapping; ``channels`` is what tells it from a cut's.
CELL_TABLES = ("log", "channels", "sensors", "phases", "outcome")


@dataclass(frozen=True)
class LogSource:
    """The ``[log]`` table.

    Attributes:
        scenario: the scenario file the cell ran, from the mapping file's folder.
        seed: the seed it ran with (None: the scenario's own).
        time_zero_s: the time of the episode's start, s since the epoch; None: the earliest
            message of the mapped topics.
    """

    scenario: str
    seed: int | None = None
    time_zero_s: float | None = None


@dataclass(frozen=True)
class ChannelTopics:
    """One ``[channels.<name>]`` table: a sensor's topics.

    Attributes:
        wrench: a ``WrenchStamped`` (or ``Wrench``) topic: the force and torque the meat
            exerts on the sensor's tool, in the sensor's frame (the fixture's: world).
        pose: a ``PoseStamped`` or ``TransformStamped`` topic: the sensor frame in the world
            (not for the fixture); sampled at the wrench's times.
        grasp: a topic of ``std_msgs`` ``Float64``, ``Int*`` or ``Bool``: 1 while the jaws hold
            (the gripper's); empty: none.
        torque: whether the log's channel keeps the wrench's torque.
        sign: +1 where the wrench is the meat's on the tool, -1 where it is the tool's on the
            meat.
    """

    wrench: str
    pose: str = ""
    grasp: str = ""
    torque: bool = True
    sign: float = 1.0

    def __post_init__(self) -> None:
        if self.sign not in (1.0, -1.0):
            raise MappingError(None, "sign", f"must be 1 or -1, got {self.sign}")


@dataclass(frozen=True)
class CellMapping:
    """A whole cell's mapping file (module docstring)."""

    log: LogSource
    channels: dict[str, ChannelTopics]
    sensors: dict[str, float] = field(default_factory=dict)
    cut_windows_s: tuple[tuple[float, float], ...] = ()
    outcome: dict[str, int] = field(default_factory=dict)
    path: Path | None = None


def is_cell_mapping(raw: dict[str, Any]) -> bool:
    """Whether the TOML tables ``raw`` map a whole cell's log (they have ``[channels]``)."""
    return "channels" in raw


def cell_mapping_from_toml(raw: dict[str, Any], path: Path | None = None) -> CellMapping:
    """The mapping in the TOML tables ``raw`` (read from ``path``, for errors).

    Raises:
        MappingError: a missing or unknown table, channel or key, or a bad value, naming it.
    """
    unknown = sorted(set(raw) - set(CELL_TABLES))
    if unknown:
        raise MappingError(path, unknown[0], f"unknown table (tables: {', '.join(CELL_TABLES)})")
    for name in ("log", "channels"):
        if not isinstance(raw.get(name), dict):
            raise MappingError(path, name, "missing table")
    log = from_table(LogSource, raw["log"], file=path, section="log", error=MappingError)
    channels = {}
    for name, table in raw["channels"].items():
        key = f"channels.{name}"
        if name not in CHANNELS:
            raise MappingError(path, key, f"unknown channel (channels: {', '.join(CHANNELS)})")
        if not isinstance(table, dict):
            raise MappingError(path, key, "expected a table")
        topics = from_table(ChannelTopics, table, file=path, section=key, error=MappingError)
        if CHANNELS[name] and not topics.pose:
            raise MappingError(path, f"{key}.pose", "missing: this sensor's pose topic")
        channels[name] = topics
    missing = [name for name in CHANNELS if name not in channels]
    if missing:
        raise MappingError(path, f"channels.{missing[0]}", "missing channel")
    return CellMapping(log, channels, _numbers(raw, "sensors", float, path),
                       _windows(raw.get("phases", {}), path),
                       _numbers(raw, "outcome", int, path), path)


def _numbers(raw: dict[str, Any], name: str, kind: type, path: Path | None) -> dict[str, Any]:
    table = raw.get(name, {})
    if not isinstance(table, dict):
        raise MappingError(path, name, "expected a table")
    for key, value in table.items():
        if isinstance(value, bool) or not isinstance(value, int | float) or (
                kind is int and not isinstance(value, int)):
            wanted = "an integer" if kind is int else "a number"
            raise MappingError(path, f"{name}.{key}", f"expected {wanted}, got {value!r}")
    return {key: kind(value) for key, value in table.items()}


def _windows(phases: Any, path: Path | None) -> tuple[tuple[float, float], ...]:
    windows = phases.get("cut_s", []) if isinstance(phases, dict) else None
    if not isinstance(windows, list) or not all(
            isinstance(w, list) and len(w) == 2
            and all(isinstance(v, int | float) and not isinstance(v, bool) for v in w)
            for w in windows):
        raise MappingError(path, "phases.cut_s", "expected a list of [start, end] pairs, s")
    return tuple((float(a), float(b)) for a, b in windows)


def read_cell_mapping(path: str | Path) -> CellMapping:
    """Read and check a whole cell's mapping file at ``path``."""
    path = Path(path)
    return cell_mapping_from_toml(read_toml(path, MappingError), path)
