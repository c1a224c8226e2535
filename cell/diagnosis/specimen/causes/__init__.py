"""The specimen's catalogue of causes, one module per cause (:mod:`.base` says what a cause
is), registered here in catalogue order; and the candidate material they extend
(:class:`~cell.diagnosis.specimen.causes.candidate.CandidateMaterial`).

Adding a cause is one new module with a :class:`~.base.Cause` subclass and one line in
:data:`~.registry.REGISTRY` (:mod:`.registry`).

Usage::

    REGISTRY["plasticity"].parameters(CandidateMaterial())
"""

from __future__ import annotations

from cell.diagnosis.specimen.causes.base import Cause, Parameter
from cell.diagnosis.specimen.causes.candidate import (
    EXCLUSIVE,
    SPECIMEN_VARIABILITY,
    UNEXPLAINED,
    CandidateMaterial,
    cause_of,
)
from cell.diagnosis.specimen.causes.registry import CAUSES, REGISTRY, UNIAXIAL_CAUSES, catalogue

__all__ = ["CAUSES", "EXCLUSIVE", "REGISTRY", "SPECIMEN_VARIABILITY", "UNEXPLAINED",
           "UNIAXIAL_CAUSES", "CandidateMaterial", "Cause", "Parameter", "catalogue", "cause_of"]
