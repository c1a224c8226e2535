"""Fibre direction: the specimen's fibres are turned by an angle from those its tests declare,
about the sheets' normal, the fibres towards the sheets (a specimen cut at an angle to its
fibres). The turned material's ``fibre_direction`` (and with it its sheets) carries the angle
(:func:`~cell.diagnosis.specimen.solve.fibre_turn_deg`). A turn shows only in a material that is
not isotropic across the fibre-sheet plane, and only in tests that probe that plane at several
orientations (shear modes, biaxial stretches): the search offers it only to sets with shear or
biaxial tests (:attr:`FibreDirection.needs_plane_tests`)."""

from __future__ import annotations

import math
from typing import Any

from cell.diagnosis.specimen.causes.base import Cause, Parameter, Settings

# Degrees: a specimen cut within about 30 degrees of its fibres, with a margin (docs/diagnosis.md).
_TURN_DEG = (-35.0, 35.0)


class FibreDirection(Cause):
    """The fibres' turn, degrees.

    Example:
        >>> from cell.diagnosis.specimen.causes import CandidateMaterial
        >>> [p.name for p in FibreDirection().parameters(CandidateMaterial())]
        ['fibre_turn_deg']
    """

    name = "fibre_direction"
    needs_plane_tests = True

    def parameters(self, model: Settings) -> tuple[Parameter, ...]:
        """The turn, from none."""
        return (Parameter("fibre_turn_deg", 0.0, *_TURN_DEG),)

    def fields(self, value: dict[str, float], model: Settings) -> dict[str, Any]:
        """The material's ``fibre_direction``: x (the candidate's fibres) turned towards z
        (its sheets, which the material turns alike)."""
        angle = math.radians(value["fibre_turn_deg"])
        return {"fibre_direction": (math.cos(angle), 0.0, math.sin(angle))}
