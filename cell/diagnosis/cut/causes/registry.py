"""The cut catalogue: every cause object by name, in catalogue order. Adding a cause is
its module and one line here."""

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
from cell.diagnosis.cut.causes.wedge_friction import WedgeFriction

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
    WedgeFriction(),
)}


def catalogue() -> tuple[str, ...]:
    """The names of the registered cut causes, in catalogue order."""
    return tuple(REGISTRY)
