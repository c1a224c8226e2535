"""The mapping file of ``musclecell import`` (docs/robot-logs.md): which topic of a robot's
log is the blade's wrench and in which frame, which the tool's position, how the stroke and
the blade's plane lie in that frame, how the block's top face is found, and the block and the
blade a cut-test set needs.

Example:
    >>> mapping = mapping_from_toml({
    ...     "wrench": {"topic": "/ft/wrench"}, "position": {"topic": "/tool/position"},
    ...     "cut": {"edge_direction": [0.0, 1.0, 0.0], "blade_normal": [1.0, 0.0, 0.0]},
    ...     "block": {"size_m": [0.05, 0.2, 0.06]},
    ...     "blade": {"edge_length_m": 0.2, "thickness_m": 0.002}})
    >>> mapping.cut.up.tolist(), mapping.cut.contact_force_n
    ([0.0, 0.0, 1.0], 1.0)
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cell.config import from_table, read_toml
from cell.errors import InputError, MappingError
from cell.measure.cuts import DIRECTION_TOLERANCE

_TABLES = ("wrench", "position", "cut", "block", "blade")


@dataclass(frozen=True)
class WrenchTopic:
    """The ``[wrench]`` table: the topic of the force on the blade.

    Attributes:
        topic: a bag's or MCAP file's topic, or a dump's file stem (``forces`` for
            ``forces.txt``); a ``WrenchStamped`` or ``Wrench`` message.
        frame: the frame the force is expressed in; messages naming another frame are refused.
            Empty: the cut's frame (``[cut] frame``).
        sign: +1 where the log gives the force the block exerts on the blade, -1 where it
            gives the force the blade exerts on the block.
        rotation: nine numbers, row by row, of the rotation from ``frame`` to the cut's frame
            (a sensor that does not turn while it cuts); needed when the frames differ.
    """

    topic: str
    frame: str = ""
    sign: float = 1.0
    rotation: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if self.sign not in (1.0, -1.0):
            raise InputError(None, "sign", f"must be 1 or -1, got {self.sign}")
        if self.rotation:
            matrix = np.array(self.rotation, dtype=float)
            if matrix.shape != (9,) or not np.allclose(
                    matrix.reshape(3, 3) @ matrix.reshape(3, 3).T, np.eye(3), atol=1e-3):
                raise InputError(None, "rotation", "must be nine numbers, row by row, of a "
                                 "rotation matrix (orthonormal within 1e-3)")


@dataclass(frozen=True)
class PositionTopic:
    """The ``[position]`` table: the topic of the tool's position.

    Attributes:
        topic: a ``Vector3Stamped``, ``PointStamped``, ``PoseStamped`` or ``TransformStamped``
            topic (or a dump's file stem).
        frame: the frame it is in, which must be the cut's; empty: the cut's frame.
        edge_offset_m: from the logged point to the edge's midpoint, in the cut's frame, m.
    """

    topic: str
    frame: str = ""
    edge_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class CutFrame:
    """The ``[cut]`` table: the cut's frame and how the block's top face is found in it.

    The block frame of the set is (``blade_normal``, ``edge_direction``, up), up their cross
    product; exactly one of the three ways to the top face is given, or none (then a contact
    threshold of 1 N).

    Attributes:
        edge_direction: unit vector along the edge, the stroke of a sawing cut.
        blade_normal: unit normal of the blade's plane, perpendicular to the edge.
        frame: the frame's name, as the messages' ``header.frame_id`` give it ("" unchecked).
        contact_force_n: the top face is where the edge was when the force, less its first
            sample (the sensor's offset in air), first exceeds this, N.
        top_height_m: or the top face's height along up, m.
        board_height_m: or the board's height along up (the top face is the block's height
            above it), m.
    """

    edge_direction: tuple[float, float, float]
    blade_normal: tuple[float, float, float]
    frame: str = ""
    contact_force_n: float | None = None
    top_height_m: float | None = None
    board_height_m: float | None = None

    def __post_init__(self) -> None:
        for name in ("edge_direction", "blade_normal"):
            if abs(float(np.linalg.norm(getattr(self, name))) - 1.0) > DIRECTION_TOLERANCE:
                raise InputError(None, name, f"must be a unit vector, got "
                                 f"{list(getattr(self, name))}")
        if abs(float(np.dot(self.edge_direction, self.blade_normal))) > DIRECTION_TOLERANCE:
            raise InputError(None, "blade_normal", "must be perpendicular to edge_direction")
        ways = [n for n in ("contact_force_n", "top_height_m", "board_height_m")
                if getattr(self, n) is not None]
        if len(ways) > 1:
            raise InputError(None, ways[1], f"give one of contact_force_n, top_height_m and "
                             f"board_height_m, not {' and '.join(ways)}")
        if not ways:
            object.__setattr__(self, "contact_force_n", 1.0)
        if self.contact_force_n is not None and not self.contact_force_n > 0.0:
            raise InputError(None, "contact_force_n", f"must be > 0, got {self.contact_force_n}")

    @property
    def up(self) -> np.ndarray:
        """The block's up, ``blade_normal`` x ``edge_direction``."""
        return np.cross(self.blade_normal, self.edge_direction)

    @property
    def axes(self) -> np.ndarray:
        """(3, 3) the block frame's axes as rows, in the cut's frame."""
        return np.array([self.blade_normal, self.edge_direction, self.up])


@dataclass(frozen=True)
class BlockSize:
    """The ``[block]`` table: the block's size (x along the blade's normal, y along the edge,
    z its height), m, the fibres' direction in the block frame (optional) and its section
    (``box``, or ``round``: a vegetable lying along x, :class:`cell.measure.cuts.Block`)."""

    size_m: tuple[float, float, float]
    fibre_direction: tuple[float, float, float] | None = None
    section: str = "box"


@dataclass(frozen=True)
class BladeShape:
    """The ``[blade]`` table: the edge's length, the spine's thickness (m), the bevel's
    included angle (degrees, optional) and the edge's radius (m, optional)."""

    edge_length_m: float
    thickness_m: float
    edge_angle_deg: float | None = None
    edge_radius_m: float | None = None


@dataclass(frozen=True)
class ImportMapping:
    """A whole mapping file (module docstring)."""

    wrench: WrenchTopic
    position: PositionTopic
    cut: CutFrame
    block: BlockSize
    blade: BladeShape
    path: Path | None = None


def mapping_from_toml(raw: dict[str, Any], path: Path | None = None) -> ImportMapping:
    """The mapping in the TOML tables ``raw`` (read from ``path``, for errors).

    Raises:
        MappingError: a missing or unknown table or key, or a bad value, naming it.
    """
    unknown = sorted(set(raw) - set(_TABLES))
    if unknown:
        raise MappingError(path, unknown[0], f"unknown table (tables: {', '.join(_TABLES)})")
    types = (WrenchTopic, PositionTopic, CutFrame, BlockSize, BladeShape)
    tables = {}
    for name, cls in zip(_TABLES, types, strict=True):
        if not isinstance(raw.get(name), dict):
            raise MappingError(path, name, "missing table")
        tables[name] = from_table(cls, raw[name], file=path, section=name, error=MappingError)
    return ImportMapping(**tables, path=path)


def read_mapping(path: str | Path) -> ImportMapping:
    """Read and check the mapping file at ``path`` (:func:`mapping_from_toml`)."""
    path = Path(path)
    return mapping_from_toml(read_toml(path, MappingError), path)
