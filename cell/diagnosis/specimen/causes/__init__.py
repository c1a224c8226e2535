"""The specimen's catalogue of causes, one module per cause (:mod:`.base` says what a cause
is), registered here in catalogue order; and the candidate material they extend
(:class:`~cell.diagnosis.specimen.causes.candidate.CandidateMaterial`).

Adding a cause is one new module with a :class:`~.base.Cause` subclass and one line in
:data:`REGISTRY`.

Usage::

    REGISTRY["plasticity"].parameters(CandidateMaterial())
"""

from __future__ import annotations

from cell.diagnosis.specimen.causes.anisotropy import Anisotropy
from cell.diagnosis.specimen.causes.asymmetry import TensionCompressionAsymmetry
from cell.diagnosis.specimen.causes.base import Cause, Parameter
from cell.diagnosis.specimen.causes.nonlinear_viscoelasticity import NonlinearViscoelasticity
from cell.diagnosis.specimen.causes.offset import ForceOffset
from cell.diagnosis.specimen.causes.plasticity import Plasticity
from cell.diagnosis.specimen.causes.stiffening import StrainStiffening
from cell.diagnosis.specimen.causes.viscoelasticity import Viscoelasticity

#: Every cause by name, in catalogue order (a model's parameters follow it).
REGISTRY: dict[str, Cause] = {cause.name: cause for cause in (
    StrainStiffening(),
    Anisotropy(),
    Viscoelasticity(),
    NonlinearViscoelasticity(),
    TensionCompressionAsymmetry(),
    Plasticity(),
    ForceOffset(),
)}


def catalogue() -> tuple[str, ...]:
    """The names of the registered causes, in catalogue order."""
    return tuple(REGISTRY)


#: The catalogue as it ships (:func:`catalogue` reads a registry that has grown).
CAUSES = catalogue()

from cell.diagnosis.specimen.causes.candidate import (  # noqa: E402  (it reads REGISTRY)
    EXCLUSIVE,
    SPECIMEN_VARIABILITY,
    UNEXPLAINED,
    CandidateMaterial,
    cause_of,
)

__all__ = ["CAUSES", "EXCLUSIVE", "REGISTRY", "SPECIMEN_VARIABILITY", "UNEXPLAINED",
           "CandidateMaterial", "Cause", "Parameter", "catalogue", "cause_of"]
