"""Strain stiffening: both moduli follow the exponential law E exp(b ``|r - 1|``) or the
paper's polynomial E (1 + k (r - 1)**2), b or k apart in tension and compression."""

from __future__ import annotations

from cell.diagnosis.specimen.causes.base import Cause, Parameter, Settings

_LAWS = {"exponential": ("stiffening_exponent", 4.0, 40.0),
         "polynomial": ("stiffening_quadratic", 10.0, 400.0)}


class StrainStiffening(Cause):
    """The stiffening law's coefficient, in tension and its own in compression (the lattice
    stiffens apart there, and one coefficient would name an asymmetry in every stiffening
    set).

    Example:
        >>> from cell.diagnosis.specimen.causes import CandidateMaterial
        >>> [p.name for p in StrainStiffening().parameters(CandidateMaterial())]
        ['stiffening_exponent', 'compression_stiffening_exponent']
    """

    name = "strain_stiffening"

    def parameters(self, model: Settings) -> tuple[Parameter, ...]:
        """The coefficient of ``model``'s law, in tension then in compression."""
        coefficient, initial, high = _LAWS[model.stiffening]
        return (Parameter(coefficient, initial, 0.0, high),
                Parameter(f"compression_{coefficient}", initial, 0.0, high))
