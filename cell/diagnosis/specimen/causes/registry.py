"""The specimen catalogue: every cause object by name, in catalogue order. Adding a cause is
its module and one line here."""

from __future__ import annotations

from cell.diagnosis.specimen.causes.anisotropy import Anisotropy
from cell.diagnosis.specimen.causes.asymmetry import TensionCompressionAsymmetry
from cell.diagnosis.specimen.causes.base import Cause
from cell.diagnosis.specimen.causes.fibre_direction import FibreDirection
from cell.diagnosis.specimen.causes.nonlinear_viscoelasticity import NonlinearViscoelasticity
from cell.diagnosis.specimen.causes.offset import ForceOffset
from cell.diagnosis.specimen.causes.orthotropy import Orthotropy
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
    Orthotropy(),
    FibreDirection(),
)}


def catalogue(plane_tests: bool = True) -> tuple[str, ...]:
    """The names of the registered causes, in catalogue order; without ``plane_tests`` those
    that a set of uniaxial tests can show."""
    return tuple(name for name, cause in REGISTRY.items()
                 if plane_tests or not cause.needs_plane_tests)


#: The catalogue as it ships (:func:`catalogue` reads a registry that has grown).
CAUSES = catalogue()
#: The causes a set of uniaxial tests can show: what it is offered, and what the uniaxial
#: hidden-effect sets hide (:mod:`cell.synthetic.specimen`).
UNIAXIAL_CAUSES = catalogue(plane_tests=False)
