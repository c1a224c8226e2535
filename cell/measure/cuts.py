"""Cut tests: a blade on a force sensor driven through a block of tissue, read and validated.

A measurement set may hold tests of mode ``cut`` beside its uniaxial ones (docs/measured-data.md,
cut tests): ``specimen.toml`` then describes the block (``[block]``) and the
blade (``[blade]``), and each cut row of ``tests.csv`` gives the edge's midpoint (the input)
and the force the block exerts on the blade (what a model must predict), in the block frame:
the block rests on z = 0 with its corner at the origin, its top face at z = ``size_m[2]``.

Example:
    >>> block = Block((0.06, 0.04, 0.03), (1.0, 0.0, 0.0))
    >>> blade = Blade(0.12, 0.0015, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), 20.0)
    >>> t = np.linspace(0.0, 2.0, 5)
    >>> edge = np.column_stack([0.03 + 0 * t, 0.02 + 0 * t, 0.035 - 0.01 * t])
    >>> test = CutTest("press", t, edge, np.zeros((5, 3)), None)
    >>> [round(float(d), 3) for d in test.depth_m(block)]
    [-0.005, 0.0, 0.005, 0.01, 0.015]
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cell.config import FORCE_N, LENGTH_M, TIME_S, Plausible, from_table
from cell.errors import CutTestError, DirectionError, EdgeInsideBlockError, InputError
from cell.io import CsvTable
from cell.measure.testrows import require_columns, rows_of

#: The ``mode`` of a cut test's rows in ``tests.csv``.
CUT_MODE = "cut"
BLOCK_TABLE, BLADE_TABLE = "block", "blade"
#: Bevel of a blade whose ``edge_angle_deg`` is not given, degrees (a boning knife's).
DEFAULT_EDGE_ANGLE_DEG = 20.0
#: Radius of a blade's edge where ``edge_radius_m`` is not given, m: a sharpened steel
#: knife's (a few micrometres; a razor's is under one).
DEFAULT_EDGE_RADIUS_M = 5e-6
EDGE_COLUMNS = ("edge_x_m", "edge_y_m", "edge_z_m")
FORCE_COLUMNS = ("force_x_N", "force_y_N", "force_z_N")
#: Optional: all three, or none.
TORQUE_COLUMNS = ("torque_x_Nm", "torque_y_Nm", "torque_z_Nm")
CUT_COLUMNS = (*EDGE_COLUMNS, *FORCE_COLUMNS, *TORQUE_COLUMNS)
#: A first sample this far inside a face still counts as on it: a robot logs its tool's
#: position to about its repeatability, a tenth of a millimetre.
START_TOLERANCE_M = 1e-4
#: A position of the edge in the block frame, m.
EDGE_POSITION_M = Plausible(-10.0, 10.0, "m", "no blade moves further from its block than the "
                            "cell is large")
#: A torque on the blade, N m.
TORQUE_NM = Plausible(-1e4, 1e4, "N m", "six-axis sensors of robot tools read at most a few "
                      "hundred N m; a knife's torque is a few N m")
#: Two directions count as unit (or perpendicular) within this: a direction written with
#: three or four digits (0.707) is meant as unit.
DIRECTION_TOLERANCE = 1e-3
_MIN_SAMPLES = 3
#: The shapes of a block's section (:attr:`Block.section`).
BLOCK_SECTIONS = ("box", "round")


def _vector(value: tuple[float, ...], name: str) -> tuple[float, float, float]:
    """``value`` as three finite floats, or an :class:`InputError` naming ``name``."""
    if len(value) != 3 or not all(math.isfinite(v) for v in value):
        raise InputError(None, name, f"must be three finite numbers, got {value!r}")
    return (float(value[0]), float(value[1]), float(value[2]))


def _unit(value: tuple[float, ...], name: str) -> tuple[float, float, float]:
    """``value`` checked to be a unit vector (within :data:`DIRECTION_TOLERANCE`)."""
    vector = _vector(value, name)
    norm = math.sqrt(sum(v * v for v in vector))
    if abs(norm - 1.0) > DIRECTION_TOLERANCE:
        raise DirectionError(None, name, f"must be a unit vector, got {list(vector)} of "
                             f"length {norm:.6g}")
    return vector


@dataclass(frozen=True)
class Block:
    """The block a cut test cuts: a box on a rigid board, the ``[block]`` table.

    Attributes:
        size_m: edge lengths along the block's x, y and z, m; the block spans 0..size on each
            axis, resting on z = 0 with its top face at z = ``size_m[2]``.
        fibre_direction: unit direction of the muscle fibres in the block frame, or None for
            an isotropic block.
        section: ``"box"``, or ``"round"``: a cylinder lying along the block's x (a
            vegetable cut across), its section the ellipse inscribed in the box's y-z face,
            so that the edge's length in the material grows with depth as a chord.

    Raises:
        InputError: a size that is not > 0 or not plausible (:data:`cell.config.LENGTH_M`).
        DirectionError: a fibre direction that is not a unit vector (within
            :data:`DIRECTION_TOLERANCE`).

    Example:
        >>> Block((0.06, 0.04, 0.03)).top_z_m
        0.03
    """

    size_m: tuple[float, float, float]
    fibre_direction: tuple[float, float, float] | None = None
    section: str = "box"

    def __post_init__(self) -> None:
        if self.section not in BLOCK_SECTIONS:
            raise InputError(None, "section", f"must be one of {list(BLOCK_SECTIONS)}, got "
                             f"{self.section!r}")
        size = _vector(self.size_m, "size_m")
        if not all(s > 0 for s in size):
            raise InputError(None, "size_m", f"must be three lengths > 0, got {list(size)}")
        for length in size:
            LENGTH_M.check(length, None, "size_m")
        object.__setattr__(self, "size_m", size)
        if self.fibre_direction is not None:
            object.__setattr__(self, "fibre_direction",
                               _unit(self.fibre_direction, "fibre_direction"))

    @property
    def top_z_m(self) -> float:
        """Height of the top face, m."""
        return self.size_m[2]

    def surfaces_z_m(self, x_m: np.ndarray, y_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The heights of the block's bottom and top surfaces over the points (x, y), m; NaN
        off the block.

        Example:
            >>> round_block = Block((0.04, 0.05, 0.05), section="round")
            >>> [round(float(z), 4) for z in round_block.surfaces_z_m(0.02, 0.005)]
            [0.01, 0.04]
        """
        x, y = np.broadcast_arrays(np.asarray(x_m, dtype=float), np.asarray(y_m, dtype=float))
        on = (x >= 0.0) & (x <= self.size_m[0]) & (y >= 0.0) & (y <= self.size_m[1])
        if self.section == "box":
            bottom, top = np.zeros(x.shape), np.full(x.shape, self.top_z_m)
        else:
            half = 0.5 * self.top_z_m
            across = (y - 0.5 * self.size_m[1]) / (0.5 * self.size_m[1])
            rise = half * np.sqrt(np.clip(1.0 - across**2, 0.0, None))
            bottom, top = half - rise, half + rise
        return np.where(on, bottom, np.nan), np.where(on, top, np.nan)

    def holds_inside(self, point: np.ndarray, tolerance_m: float = 0.0) -> bool:
        """Whether ``point`` (3,) lies inside the block, deeper than ``tolerance_m`` (m) below
        every face: a point on a face, or within the tolerance of it, is not inside."""
        point = np.asarray(point, dtype=float)
        size = np.asarray(self.size_m)
        return bool(np.all(point > tolerance_m) and np.all(point < size - tolerance_m))


@dataclass(frozen=True)
class Blade:
    """The blade of a cut test, on its force sensor: the ``[blade]`` table.

    Attributes:
        edge_length_m: length of the cutting edge, m.
        thickness_m: thickness of the blade's spine, m.
        edge_direction: unit vector along the edge, block frame.
        blade_normal: unit normal of the blade's plane, block frame, perpendicular to
            ``edge_direction``.
        edge_angle_deg: included angle of the edge's bevel, degrees, or None if not given
            (:attr:`bevel_deg` is then :data:`DEFAULT_EDGE_ANGLE_DEG`).
        edge_radius_m: radius of the edge's rounded tip, m, >= 0 (a sharp knife's few
            micrometres by default: :data:`DEFAULT_EDGE_RADIUS_M`).

    Raises:
        InputError: a length that is not > 0 or not plausible (:data:`cell.config.LENGTH_M`),
            a bevel angle not between 0 and 180 degrees.
        DirectionError: a direction that is not a unit vector, a normal not perpendicular to
            the edge (within :data:`DIRECTION_TOLERANCE`).

    Example:
        >>> Blade(0.12, 0.0015, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), 20.0).edge_direction
        (0.0, 1.0, 0.0)
    """

    edge_length_m: float
    thickness_m: float
    edge_direction: tuple[float, float, float]
    blade_normal: tuple[float, float, float]
    edge_angle_deg: float | None = None
    edge_radius_m: float = DEFAULT_EDGE_RADIUS_M

    def __post_init__(self) -> None:
        for name in ("edge_length_m", "thickness_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InputError(None, name, f"must be > 0, got {value}")
            LENGTH_M.check(value, None, name)
        edge = _unit(self.edge_direction, "edge_direction")
        normal = _unit(self.blade_normal, "blade_normal")
        cosine = sum(e * n for e, n in zip(edge, normal, strict=True))
        if abs(cosine) > DIRECTION_TOLERANCE:
            raise DirectionError(None, "blade_normal",
                                 f"must be perpendicular to edge_direction {list(edge)}: their dot "
                                 f"product is {cosine:.6g}")
        object.__setattr__(self, "edge_direction", edge)
        object.__setattr__(self, "blade_normal", normal)
        angle = self.edge_angle_deg
        if angle is not None and not (math.isfinite(angle) and 0.0 < angle < 180.0):
            raise InputError(None, "edge_angle_deg",
                             f"must be between 0 and 180 degrees, got {angle}")
        if not (math.isfinite(self.edge_radius_m) and 0.0 <= self.edge_radius_m
                < self.thickness_m / 2):
            raise InputError(None, "edge_radius_m", f"must be >= 0 and under half the "
                             f"thickness, got {self.edge_radius_m}")

    @property
    def bevel_deg(self) -> float:
        """The bevel's included angle, degrees: ``edge_angle_deg`` or the default."""
        return self.edge_angle_deg or DEFAULT_EDGE_ANGLE_DEG


@dataclass(frozen=True, eq=False)
class CutTest:
    """One cut test (one ``test_id`` of mode ``cut``): the edge's path and the force on the
    blade. Arrays are read-only, one row per sample, in the block frame.

    Attributes:
        test_id: the test's name, unique in its set.
        time_s: (n,) time since the start of the test, s, strictly increasing (samples need
            not be evenly spaced; a robot's log drops some).
        edge_m: (n, 3) position of the edge's midpoint, m.
        force_n: (n, 3) force the block exerts on the blade, N (the sensor's offset in air is
            part of the data).
        torque_nm: (n, 3) torque on the blade about the edge's midpoint, N m, or None when the
            sensor gives none.

    Raises:
        InputError: arrays of the wrong shape or not finite, time not strictly increasing.

    Example:
        >>> t = np.array([0.0, 0.1, 0.3])
        >>> edge = np.array([[0.03, 0.02, 0.031], [0.03, 0.02, 0.030], [0.03, 0.02, 0.028]])
        >>> test = CutTest("c0", t, edge, np.zeros((3, 3)), None)
        >>> blade = Blade(0.1, 1e-3, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
        >>> test.duration_s, float(test.stroke_m(blade)[-1])
        (0.3, 0.0)
    """

    test_id: str
    time_s: np.ndarray
    edge_m: np.ndarray
    force_n: np.ndarray
    torque_nm: np.ndarray | None = None

    def __post_init__(self) -> None:
        time = np.array(self.time_s, dtype=float)
        if time.ndim != 1 or len(time) < 2:
            raise InputError(None, "time_s", f"test {self.test_id!r}: needs at least 2 samples "
                             f"in a 1-D array, got shape {time.shape}")
        shapes = {"time_s": time}
        for name in ("edge_m", "force_n", "torque_nm"):
            value = getattr(self, name)
            if value is None:
                continue
            array = np.array(value, dtype=float)
            if array.shape != (len(time), 3):
                raise InputError(None, name, f"test {self.test_id!r}: expected shape "
                                 f"({len(time)}, 3), got {array.shape}")
            shapes[name] = array
        for name, array in shapes.items():
            if not np.all(np.isfinite(array)):
                raise InputError(None, name, f"test {self.test_id!r}: not finite")
            array.setflags(write=False)
            object.__setattr__(self, name, array)
        if np.any(np.diff(time) <= 0.0):
            raise InputError(None, "time_s", f"test {self.test_id!r}: time must be strictly "
                             "increasing")

    @property
    def duration_s(self) -> float:
        """Time from the first to the last sample, s."""
        return float(self.time_s[-1] - self.time_s[0])

    def depth_m(self, block: Block) -> np.ndarray:
        """(n,) depth of the edge's midpoint below the block's top face, m (negative above)."""
        return block.top_z_m - self.edge_m[:, 2]

    def stroke_m(self, blade: Blade) -> np.ndarray:
        """(n,) travel of the edge along itself since the first sample, m: a sawing cut's
        stroke (zero for a press cut)."""
        return (self.edge_m - self.edge_m[0]) @ np.asarray(blade.edge_direction)


def cut_rows_csv(tests: Sequence[CutTest]) -> str:
    """The ``tests.csv`` of a set of cut tests (torques left out), as the reader reads it:
    time to the microsecond, positions to 10 nm, forces to 0.1 mN.

    Example:
        >>> t = np.array([0.0, 0.5])
        >>> print(cut_rows_csv([CutTest("c", t, np.ones((2, 3)), np.zeros((2, 3)))]), end="")
        test_id,mode,time_s,edge_x_m,edge_y_m,edge_z_m,force_x_N,force_y_N,force_z_N
        c,cut,0.000000,1.00000000,1.00000000,1.00000000,0.0000,0.0000,0.0000
        c,cut,0.500000,1.00000000,1.00000000,1.00000000,0.0000,0.0000,0.0000
    """
    rows = [",".join(("test_id", "mode", "time_s", *EDGE_COLUMNS, *FORCE_COLUMNS))]
    for test in tests:
        rows += [f"{test.test_id},{CUT_MODE},{t:.6f},{e[0]:.8f},{e[1]:.8f},{e[2]:.8f},"
                 f"{f[0]:.4f},{f[1]:.4f},{f[2]:.4f}"
                 for t, e, f in zip(test.time_s, test.edge_m, test.force_n, strict=True)]
    return "\n".join(rows) + "\n"


def read_cut_tables(path: Path, raw: Mapping[str, Any]) -> tuple[Block | None, Blade | None]:
    """The ``[block]`` and ``[blade]`` tables of ``specimen.toml`` (``raw``, read from
    ``path``), None for one that is absent.

    Raises:
        CutTestError: naming the file and the dotted key: an unknown key, a wrong type, a
            missing key without default, a length not > 0 or implausible;
            :class:`~cell.errors.DirectionError` for a direction that is not unit or a
            normal not perpendicular to the edge.
    """
    block = (from_table(Block, raw[BLOCK_TABLE], file=path, section=BLOCK_TABLE,
                        error=CutTestError) if BLOCK_TABLE in raw else None)
    blade = (from_table(Blade, raw[BLADE_TABLE], file=path, section=BLADE_TABLE,
                        error=CutTestError) if BLADE_TABLE in raw else None)
    return block, blade


def read_cut_tests(table: CsvTable, groups: Mapping[str, Sequence[int]], block: Block | None,
                   blade: Blade | None, specimen_path: Path) -> tuple[CutTest, ...]:
    """The cut tests of ``tests.csv`` (``table``; ``groups``: the row indices of each test
    whose first row is of mode ``cut``), checked against the set's block and blade.

    The columns of uniaxial tests are not needed, and the rows of uniaxial tests may leave
    these columns empty.

    Raises:
        CutTestError: naming the file and the table, or the line and column: no ``[block]``
            or ``[blade]`` in ``specimen_path``, a test whose mode changes, fewer than 3
            samples, time that does not strictly increase.
        CsvError: a missing column (the torque's only when one of the three is given), a
            value that is not a finite number or not plausible.
        EdgeInsideBlockError: a test whose first sample has the edge inside the block, deeper
            than :data:`START_TOLERANCE_M`.
    """
    if not groups:
        return ()
    if block is None or blade is None:
        raise CutTestError(specimen_path, BLOCK_TABLE if block is None else BLADE_TABLE,
                           f"missing table: {table.path.name} holds cut tests "
                           f"({next(iter(groups))!r} is one), which need [block] and [blade]")
    needed = (*EDGE_COLUMNS, *FORCE_COLUMNS)
    if any(name in table.cells for name in TORQUE_COLUMNS):
        needed = (*needed, *TORQUE_COLUMNS)
    require_columns(table, needed)
    cuts, rows = rows_of(table, groups)
    plausible = {"time_s": TIME_S, **dict.fromkeys(EDGE_COLUMNS, EDGE_POSITION_M),
                 **dict.fromkeys(FORCE_COLUMNS, FORCE_N),
                 **dict.fromkeys(TORQUE_COLUMNS, TORQUE_NM)}
    values = {name: cuts.numbers(name, plausible[name].refusal) for name in ("time_s", *needed)}
    return tuple(_cut_test(cuts, values, test_id, members, block)
                 for test_id, members in rows.items())


def _cut_test(table: CsvTable, values: Mapping[str, np.ndarray], test_id: str,
              rows: list[int], block: Block) -> CutTest:
    """Validate and convert the rows of one cut test (``rows``: indices into ``table``)."""
    path = table.path
    for row in rows:
        mode = table.cells["mode"][row]
        if mode != CUT_MODE:
            raise CutTestError(path, table.where(row, "mode"),
                               f"test {test_id!r} changes mode from {CUT_MODE!r} to {mode!r}")
    if len(rows) < _MIN_SAMPLES:
        raise CutTestError(path, table.where(rows[0], "test_id"),
                           f"test {test_id!r} has {len(rows)} samples, needs at least "
                           f"{_MIN_SAMPLES}")
    time = values["time_s"][rows]
    stalled = np.flatnonzero(np.diff(time) <= 0.0)
    if stalled.size:
        row = int(stalled[0]) + 1
        raise CutTestError(path, table.where(rows[row], "time_s"),
                           f"time must increase in cut test {test_id!r}: {time[row]:g} s "
                           f"after {time[row - 1]:g} s")
    edge = _vectors(values, EDGE_COLUMNS, rows)
    if block.holds_inside(edge[0], START_TOLERANCE_M):
        raise EdgeInsideBlockError(
            path, table.where(rows[0], "edge_z_m"),
            f"cut test {test_id!r} starts with the edge at {edge[0].tolist()} m, inside the "
            f"block (0 to {list(block.size_m)} m): a cut starts with the edge above the top "
            "face or beside the block")
    torque = _vectors(values, TORQUE_COLUMNS, rows) if TORQUE_COLUMNS[0] in values else None
    return CutTest(test_id, time, edge, _vectors(values, FORCE_COLUMNS, rows), torque)


def _vectors(values: Mapping[str, np.ndarray], columns: Sequence[str], rows: list[int]
             ) -> np.ndarray:
    """(len(rows), 3) the three ``columns`` of a vector at ``rows``."""
    return np.column_stack([values[name][rows] for name in columns])
