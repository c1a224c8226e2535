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
_FEET = 32


@dataclass(frozen=True)
class Collision:
    """A ``contype``/``conaffinity`` pair for one kind of body.

    Example:
        >>> import mujoco
        >>> spec = mujoco.MjSpec()
        >>> top = spec.worldbody.add_geom(size=[0.5, 0.5, 0.01], contype=TABLE_TOP.contype,
        ...                               conaffinity=TABLE_TOP.conaffinity)
        >>> bool(TABLE_TOP.contype & FEET.conaffinity), bool(TABLE_TOP.contype & JAWS.conaffinity)
        (True, False)
    """

    contype: int
    conaffinity: int


#: Arms and tools (MuJoCo's default bits): they touch everything but the jaws.
ROBOTS = Collision(_ROBOT, _ROBOT)
#: The table carries the shank on small spheres at its bottom vertices ("feet"): a flex
#: resting on a box makes several element contacts per vertex, and those contacts were most
#: of a step's time (measured on the default cell). The round's bottom is pinned to the
#: fixture, so it needs no table contact at all.
TABLE_TOP = Collision(_TABLE, _ROBOT | _FEET)
FEET = Collision(_FEET, _TABLE)


def muscles(touch_each_other: bool) -> tuple[Collision, Collision]:
    """Bits of the round and the shank. Contact between the two flexes is optional: its
    flex-flex midphase cost more than everything else in a step (measured on the default
    cell), and while they are bound the bindings keep them apart anyway."""
    between = (_SHANK, _ROUND) if touch_each_other else (0, 0)
    return Collision(_ROUND, _ROBOT | between[0]), Collision(_SHANK, _ROBOT | between[1])
#: The pinch is modelled by grasp bindings; jaw-tissue contact would only fight them.
JAWS = Collision(_JAWS, _JAWS)
