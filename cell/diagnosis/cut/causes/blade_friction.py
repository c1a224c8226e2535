"""Blade friction: the faces drag with ``mu p`` over the blade's area in the material (the shear
stress ``face_shear_pa``, solved in closed form)."""

from __future__ import annotations

from cell.diagnosis.cut.causes.base import CutCause, CutSettings


class BladeFriction(CutCause):
    """Blade friction: the faces drag with ``mu p`` over the blade's area in the material (the
    shear stress ``face_shear_pa``, solved in closed form).

    Example:
        >>> from cell.diagnosis.cut.causes import CutCandidate
        >>> BladeFriction().linear(CutCandidate())
        ('face_shear_pa',)
    """

    name = "blade_friction"

    def linear(self, model: CutSettings) -> tuple[str, ...]:
        """Its parameters solved in closed form."""
        return ("face_shear_pa",)
