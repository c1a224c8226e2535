"""Separation logs on disk (docs/logs.md; the format: docs/log-format.md): a folder
with ``log.toml``, ``knife.csv``, ``gripper.csv`` and ``fixture.csv``, read through the
guarded reader (:mod:`cell.io`) with a named error for every fault, and written as text.

A channel holds a sensor's samples over time: its frame's pose in the world (m, unit
quaternion w x y z; not for the fixture) and the force (and torque) the meat exerts on it, N
and N m, in the sensor's frame (the fixture's in the world frame). This module reads and
writes; it runs nothing (MuJoCo-free).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from cell.config import read_toml
from cell.errors import (
    CsvError,
    LogError,
    LogScenarioError,
    MissingChannelError,
    QuaternionError,
    SampleError,
    TimeOrderError,
)
from cell.io import CsvTable, read_csv

POSE = ("x_m", "y_m", "z_m", "qw", "qx", "qy", "qz")
FORCE = ("force_x_N", "force_y_N", "force_z_N")
TORQUE = ("torque_x_Nm", "torque_y_Nm", "torque_z_Nm")
#: The channels of a log: file stem -> whether it carries a pose. The one list of them: the
#: reader, the writer (:mod:`cell.sim.episodelog`), the replay's comparison, the diagnosis's
#: force vector and the hidden offsets of the synthetic batches read it (each channel is also
#: a sensor of the cell: ``<stem>/force`` in its model).
CHANNELS = {"knife": True, "gripper": True, "fixture": False}
#: How far a quaternion's norm may be off 1 (the four decimals a log may be written with).
QUATERNION_TOLERANCE = 1e-3


@dataclass(frozen=True)
class Channel:
    """One sensor's samples.

    Attributes:
        time_s: (N,) sample times, increasing, s.
        force_n: (N, 3) the force the meat exerts on the sensor, N.
        torque_nm: (N, 3) its torque, N m, or None when not logged.
        position_m: (N, 3) the sensor frame's origin in the world, m (None: the fixture).
        quaternion: (N, 4) its orientation, unit, w x y z (None: the fixture).
        grasp: (N,) 1 while the jaws hold the meat, 0 open (the gripper's, else None).

    Example:
        >>> channel = Channel(np.array([0.0, 0.1]), np.zeros((2, 3)))
        >>> channel.peak_n()
        0.0
    """

    time_s: np.ndarray
    force_n: np.ndarray
    torque_nm: np.ndarray | None = None
    position_m: np.ndarray | None = None
    quaternion: np.ndarray | None = None
    grasp: np.ndarray | None = None

    def peak_n(self) -> float:
        """The largest force the channel read, N."""
        return float(np.linalg.norm(self.force_n, axis=1).max(initial=0.0))


@dataclass(frozen=True)
class SeparationLog:
    """A separation log read from its folder.

    Attributes:
        folder: where it was read.
        name: its name.
        scenario: the scenario file it names (resolved from the folder).
        seed: the seed the episode ran with (None: the scenario's own).
        channels: ``knife``, ``gripper`` and ``fixture``.
        sensors: the ``[sensors]`` table: rates (Hz) and the times the sensors were tared
            (``<channel>_tare_s``; a channel without one is tared at its first sample).
        cut_windows_s: when the knife cut, per pass (start, end), s; empty when not given.
        outcome: the ``[outcome]`` table where given: ``bindings``, ``released``, ``torn``.
    """

    folder: Path
    name: str
    scenario: Path
    seed: int | None
    channels: dict[str, Channel]
    sensors: dict[str, float] = field(default_factory=dict)
    cut_windows_s: tuple[tuple[float, float], ...] = ()
    outcome: dict[str, int] = field(default_factory=dict)


def _table(raw: dict[str, Any], path: Path, name: str) -> dict[str, Any]:
    table = raw.get(name, {})
    if not isinstance(table, dict):
        raise LogError(path, name, "expected a table")
    return table


def _number(value: Any, path: Path, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value):
        raise LogError(path, key, f"expected a finite number, got {value!r}")
    return float(value)


def _windows(value: Any, path: Path) -> tuple[tuple[float, float], ...]:
    if not isinstance(value, list) or not all(isinstance(w, list) and len(w) == 2
                                              for w in value):
        raise LogError(path, "phases.cut_s", "expected a list of [start, end] pairs, s")
    windows = tuple((_number(a, path, "phases.cut_s"), _number(b, path, "phases.cut_s"))
                    for a, b in value)
    if any(b < a for a, b in windows):
        raise LogError(path, "phases.cut_s", "a window ends before it starts")
    return windows


def read_log(folder: str | Path) -> SeparationLog:
    """Read the log in ``folder``.

    Raises:
        LogError: (and its kinds in :mod:`cell.errors`) naming file and key, or line and
            column: a missing channel, a sample that is not a finite number, a quaternion
            that is not a unit one, time that does not increase, a scenario that is not there.

    Example:
        >>> read_log("no/such/log")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        cell.errors.MissingFileError: no/such/log/log.toml: file not found
    """
    folder = Path(folder)
    path = folder / "log.toml"
    raw = read_toml(path, LogError)
    unknown = sorted(set(raw) - {"log", "sensors", "phases", "outcome"})
    if unknown:
        raise LogError(path, unknown[0] or '""',
                       "unknown table (known: log, sensors, phases, outcome)")
    head = _table(raw, path, "log")
    name, scenario, seed = head.get("name", folder.name), head.get("scenario"), head.get("seed")
    if not isinstance(name, str):
        raise LogError(path, "log.name", "expected text")
    if not isinstance(scenario, str) or not scenario:
        raise LogError(path, "log.scenario", "missing: the scenario file the log ran")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
        raise LogError(path, "log.seed", f"expected an integer >= 0, got {seed!r}")
    if not _is_file(folder / scenario):
        raise LogScenarioError(path, "log.scenario", f"no scenario file at {scenario!r} "
                               f"(a path from the log's folder, {folder})")
    sensors = {key: _number(value, path, f"sensors.{key}")
               for key, value in _table(raw, path, "sensors").items()}
    phases = _table(raw, path, "phases")
    windows = _windows(phases["cut_s"], path) if "cut_s" in phases else ()
    outcome = {key: int(_number(value, path, f"outcome.{key}"))
               for key, value in _table(raw, path, "outcome").items()}
    channels = {stem: read_channel(folder / f"{stem}.csv", pose)
                for stem, pose in CHANNELS.items()}
    return SeparationLog(folder, name, folder / scenario, seed, channels, sensors, windows,
                         outcome)


def _is_file(path: Path) -> bool:
    try:
        return path.is_file()
    except OSError:  # a name the system refuses (too long)
        return False


def read_channel(path: Path, pose: bool) -> Channel:
    """One channel's CSV file (a pose and a force, or a force alone; torques and ``grasp``
    where given).

    Raises:
        LogError: as :func:`read_log`.
    """
    needed = ("time_s", *(POSE if pose else ()), *FORCE)
    if not path.is_file():
        raise MissingChannelError(path, None, "missing channel: no such file")
    try:
        table = read_csv(path, ["time_s"], [*needed, *TORQUE, "grasp"])
    except CsvError as exc:
        raise LogError(exc.file, exc.field, exc.message) from None
    for column in needed:
        if column not in table.cells:
            raise MissingChannelError(path, f"column {column}", "missing column")
    if not table.lines:
        raise LogError(path, None, "no samples")
    values = {column: _column(table, column) for column in table.cells}
    time_s = values["time_s"]
    backwards = np.flatnonzero(np.diff(time_s) <= 0.0)
    if backwards.size:
        raise TimeOrderError(path, table.where(int(backwards[0]) + 1, "time_s"),
                             "time does not increase from the sample before")
    stack = lambda columns: np.stack([values[c] for c in columns], axis=1)  # noqa: E731
    torque = stack(TORQUE) if all(c in values for c in TORQUE) else None
    grasp = values.get("grasp")
    if grasp is not None and not np.isin(grasp, (0.0, 1.0)).all():
        row = int(np.flatnonzero(~np.isin(grasp, (0.0, 1.0)))[0])
        raise SampleError(path, table.where(row, "grasp"), "expected 0 (open) or 1 (closed)")
    if not pose:
        return Channel(time_s, stack(FORCE), torque)
    quaternion = stack(POSE[3:])
    off = np.flatnonzero(np.abs(np.linalg.norm(quaternion, axis=1) - 1.0)
                         > QUATERNION_TOLERANCE)
    if off.size:
        raise QuaternionError(path, table.where(int(off[0]), "qw"),
                              f"not a unit quaternion (norm "
                              f"{np.linalg.norm(quaternion[off[0]]):.6g})")
    return Channel(time_s, stack(FORCE), torque, stack(POSE[:3]), quaternion, grasp)


def _column(table: CsvTable, column: str) -> np.ndarray:
    try:
        return table.numbers(column)
    except CsvError as exc:
        raise SampleError(exc.file, exc.field, exc.message) from None


def channel_rows(channel: Channel) -> tuple[list[str], list[dict[str, float]]]:
    """The columns and rows of ``channel`` as its CSV file holds them."""
    columns = ["time_s"]
    parts: list[tuple[tuple[str, ...], np.ndarray | None]] = [
        (POSE[:3], channel.position_m), (POSE[3:], channel.quaternion),
        (FORCE, channel.force_n), (TORQUE, channel.torque_nm)]
    present = [(names, values) for names, values in parts if values is not None]
    for names, _ in present:
        columns += names
    if channel.grasp is not None:
        columns.append("grasp")
    rows = []
    for i, time_s in enumerate(channel.time_s):
        row = {"time_s": float(time_s)}
        for names, values in present:
            row.update(zip(names, map(float, values[i]), strict=True))
        if channel.grasp is not None:
            row["grasp"] = int(channel.grasp[i])
        rows.append(row)
    return columns, rows


def log_toml(name: str, scenario: str, seed: int | None, sensors: dict[str, float],
             cut_windows_s: tuple[tuple[float, float], ...], outcome: dict[str, int]) -> str:
    """The text of a ``log.toml`` (``seed`` None: the scenario's own, no ``seed`` key)."""
    quoted = lambda text: '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'  # noqa: E731
    lines = ["[log]", f"name = {quoted(name)}", f"scenario = {quoted(scenario)}",
             *([] if seed is None else [f"seed = {seed}"]),
             "# Poses are of each sensor's frame, in the cell's world frame (m, unit "
             "quaternion w x y z);",
             "# forces and torques are those the meat exerts on the sensor, in its frame "
             "(the fixture's: world).", "", "[sensors]"]
    lines += [f"{key} = {value!r}" for key, value in sensors.items()]
    windows = ", ".join(f"[{a!r}, {b!r}]" for a, b in cut_windows_s)
    lines += ["", "[phases]", f"cut_s = [{windows}]", "", "[outcome]"]
    lines += [f"{key} = {value}" for key, value in outcome.items()] + [""]
    return "\n".join(lines)
