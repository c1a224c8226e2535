"""The load cell's offset: a constant force it reads (a rig effect, not part of the material
the muscles get), solved in closed form with E, so no shape parameter."""

from __future__ import annotations

from cell.diagnosis.specimen.causes.base import Cause


class ForceOffset(Cause):
    """The load cell's offset, N (a linear parameter, no shape parameter).

    Example:
        >>> from cell.diagnosis.specimen.causes import CandidateMaterial
        >>> ForceOffset().parameters(CandidateMaterial())
        ()
    """

    name = "force_offset"
