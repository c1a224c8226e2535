"""Wedge friction: the blade's thickness and bevel wedge the cut open, the faces press on it
with the modulus times the opening strain, and drag with mu times that pressure
(``face_modulus_pa``, mu E, solved in closed form): a drag that grows with the depth of blade
in the material."""

from __future__ import annotations

from cell.diagnosis.cut.causes.base import CutCause, CutSettings


class WedgeFriction(CutCause):
    """Wedge friction: the blade's thickness and bevel wedge the cut open, the faces press on
    it with the modulus times the opening strain, and drag with mu times that pressure
    (``face_modulus_pa``, mu E, solved in closed form).

    Example:
        >>> from cell.diagnosis.cut.causes import CutCandidate
        >>> WedgeFriction().linear(CutCandidate())
        ('face_modulus_pa',)
    """

    name = "wedge_friction"

    def linear(self, model: CutSettings) -> tuple[str, ...]:
        """Its parameters solved in closed form."""
        return ("face_modulus_pa",)
