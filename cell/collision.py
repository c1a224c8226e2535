"""Who touches whom in the cell: MuJoCo ``contype``/``conaffinity`` bits.

Two geoms (or a geom and a flex) collide when ``a.contype & b.conaffinity`` or
``b.contype & a.conaffinity`` is non-zero.
"""

from __future__ import annotations

from dataclasses import dataclass

_ROBOT = 1
_TABLE = 2
_SHANK = 4
_ROUND = 8
_JAWS = 16


@dataclass(frozen=True)
class Collision:
    """A ``contype``/``conaffinity`` pair for one kind of body.

    Example:
        >>> body.add_geom(contype=TABLE_TOP.contype, conaffinity=TABLE_TOP.conaffinity)
    """

    contype: int
    conaffinity: int


#: Arms and tools (MuJoCo's default bits): they touch everything but the jaws.
ROBOTS = Collision(_ROBOT, _ROBOT)
#: The table carries the shank; the round's bottom is pinned to the fixture, so its many
#: contacts with the table would only cost solver time (measured: half of a step's time).
TABLE_TOP = Collision(_TABLE, _ROBOT | _SHANK)
SHANK = Collision(_SHANK, _ROBOT | _TABLE | _ROUND)
ROUND = Collision(_ROUND, _ROBOT | _SHANK)
#: The pinch is modelled by grasp bindings; jaw-tissue contact would only fight them.
JAWS = Collision(_JAWS, _JAWS)
