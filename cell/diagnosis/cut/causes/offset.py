"""The blade's force offset: the sensor reads a constant 3-vector (``offset_{x,y,z}_n``, solved
in closed form)."""

from __future__ import annotations

from cell.diagnosis.cut.causes.base import CutCause, CutSettings


class BladeForceOffset(CutCause):
    """The blade's force offset: the sensor reads a constant 3-vector (``offset_{x,y,z}_n``,
    solved in closed form).

    Example:
        >>> from cell.diagnosis.cut.causes import CutCandidate
        >>> BladeForceOffset().linear(CutCandidate())
        ('offset_x_n', 'offset_y_n', 'offset_z_n')
    """

    name = "blade_force_offset"
    column = 2

    def linear(self, model: CutSettings) -> tuple[str, ...]:
        """Its parameters solved in closed form."""
        return tuple(f"offset_{a}_n" for a in ("x", "y", "z"))
