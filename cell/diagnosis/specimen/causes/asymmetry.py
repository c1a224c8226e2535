"""Tension-compression asymmetry: El and Et of compressed springs (their logs over the tension
ones), by one factor or apart."""

from __future__ import annotations

from cell.diagnosis.specimen.causes.base import Cause, Parameter, Settings


class TensionCompressionAsymmetry(Cause):
    """The log factor of compressed springs' moduli, one or per direction.

    Example:
        >>> from cell.diagnosis.specimen.causes import CandidateMaterial
        >>> [p.name for p in TensionCompressionAsymmetry().parameters(CandidateMaterial())]
        ['log_compression']
    """

    name = "tension_compression_asymmetry"

    def parameters(self, model: Settings) -> tuple[Parameter, ...]:
        """One log factor, or El's and Et's apart."""
        names = (["log_el_compression", "log_et_compression"]
                 if model.compression_per_direction else ["log_compression"])
        return tuple(Parameter(n, 0.0, -3.0, 3.0) for n in names)
