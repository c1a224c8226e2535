"""What one cause of the specimen catalogue is (:class:`Cause`): its name, the shape parameters
it adds to a candidate material with their initial values and bounds (:class:`Parameter`), and
the fields of the mass-spring material it sets from them.

Usage::

    class Creep(Cause):
        name = "creep"
        def parameters(self, model): return (Parameter("creep_rate", 0.0, 0.0, 1.0),)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, Protocol


@dataclass(frozen=True)
class Parameter:
    """One shape parameter a cause adds: its name, initial value and bounds (the parameter's
    own units, named in its name where it has one).

    Example:
        >>> Parameter("yield_strain", 0.03, 0.002, 0.4).initial
        0.03
    """

    name: str
    initial: float
    low: float
    high: float


class Settings(Protocol):
    """The candidate material's settings that a cause's parameters depend on
    (:class:`~cell.diagnosis.specimen.causes.candidate.CandidateMaterial`)."""

    stiffening: str
    time_range_s: tuple[float, float]
    relaxation_terms: int
    oblique: bool
    compression_per_direction: bool
    reference_strain: float


class Cause:
    """A cause of the specimen catalogue: a change to the candidate material. A subclass sets
    ``name`` and overrides what it changes; the spring curves that stiffening, anisotropy and
    the asymmetry shape together are composed from their parameters by the candidate material.

    Example:
        >>> Cause().parameters(None)
        ()
    """

    name: ClassVar[str] = ""
    #: Whether only shear and biaxial tests can show the cause (a uniaxial set is not offered
    #: it).
    needs_plane_tests: ClassVar[bool] = False

    def parameters(self, model: Settings) -> tuple[Parameter, ...]:
        """The shape parameters the cause adds to ``model``, in vector order."""
        return ()

    def fields(self, value: dict[str, float], model: Settings) -> dict[str, Any]:
        """The :class:`~cell.tissue.material.MassSpringMaterial` fields the cause sets from
        the shape parameters by name (``value``); none beyond the spring curves by default."""
        return {}
