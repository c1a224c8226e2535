"""The cut catalogue of causes, one module per cause (:mod:`.base` says what a cause is),
registered here in catalogue order; and the cutting model they extend
(:class:`~cell.diagnosis.cut.causes.candidate.CutCandidate`).

Adding a cause is one new module with a :class:`~.base.CutCause` subclass and one line in
:data:`~.registry.REGISTRY` (:mod:`.registry`).

Usage::

    REGISTRY["slicing"].parameters(CutCandidate())
"""

from __future__ import annotations

from cell.diagnosis.cut.causes.base import CutCause
from cell.diagnosis.cut.causes.candidate import (
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
from cell.diagnosis.cut.causes.registry import REGISTRY, catalogue

__all__ = ["CUT_CAUSES", "FACE_PRESSURE_PA", "REGISTRY", "REPORTED_SPEED_M_S", "SOURCE_RANGES",
           "CutCandidate", "CutCause", "catalogue", "cause_of", "flat", "linear_columns",
           "source_checks"]
