"""The cut catalogue of causes, one module per cause (:mod:`.base` says what a cause is),
registered here in catalogue order; and the cutting model they extend
(:class:`~cell.diagnosis.cut.causes.candidate.CutCandidate`).

Adding a cause is one new module with a :class:`~.base.CutCause` subclass and one line in
:data:`REGISTRY`.

Usage::

    REGISTRY["slicing"].parameters(CutCandidate())
"""

from __future__ import annotations

from cell.diagnosis.cut.causes.base import CutCause
from cell.diagnosis.cut.causes.blade_friction import BladeFriction
from cell.diagnosis.cut.causes.edge_friction import EdgeFriction
from cell.diagnosis.cut.causes.edge_loading import EdgeLoading
from cell.diagnosis.cut.causes.indentation_stiffness import IndentationStiffness
from cell.diagnosis.cut.causes.layered_toughness import LayeredToughness
from cell.diagnosis.cut.causes.offset import BladeForceOffset
from cell.diagnosis.cut.causes.rate_dependent_cutting import RateDependentCutting
from cell.diagnosis.cut.causes.slicing import Slicing

#: Every cause by name, in catalogue order (:data:`cell.tissue.cutmodel.CUT_CAUSES` as it
#: ships; a model's shape parameters follow it).
REGISTRY: dict[str, CutCause] = {cause.name: cause for cause in (
    BladeFriction(),
    Slicing(),
    RateDependentCutting(),
    IndentationStiffness(),
    LayeredToughness(),
    BladeForceOffset(),
    EdgeLoading(),
    EdgeFriction(),
)}


def catalogue() -> tuple[str, ...]:
    """The names of the registered cut causes, in catalogue order."""
    return tuple(REGISTRY)


from cell.diagnosis.cut.causes.candidate import (  # noqa: E402  (it reads REGISTRY)
    CUT_CAUSES,
    FACE_PRESSURE_PA,
    REPORTED_SPEED_M_S,
    SOURCE_RANGES,
    CutCandidate,
    cause_of,
    flat,
    linear_columns,
    source_checks,
)

__all__ = ["CUT_CAUSES", "FACE_PRESSURE_PA", "REGISTRY", "REPORTED_SPEED_M_S", "SOURCE_RANGES",
           "CutCandidate", "CutCause", "catalogue", "cause_of", "flat", "linear_columns",
           "source_checks"]
