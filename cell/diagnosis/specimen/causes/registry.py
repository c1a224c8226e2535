"""The specimen catalogue: every cause object by name, in catalogue order. Adding a cause is
its module and one line here."""

from __future__ import annotations

from cell.diagnosis.specimen.causes.anisotropy import Anisotropy
from cell.diagnosis.specimen.causes.asymmetry import TensionCompressionAsymmetry
from cell.diagnosis.specimen.causes.base import Cause
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
