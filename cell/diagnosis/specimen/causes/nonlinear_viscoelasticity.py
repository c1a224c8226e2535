"""Non-linear viscoelasticity: the quasi-linear relaxation, its relaxed fraction (held at the
set's reference strain) growing or shrinking linearly with the strain held (its slope per unit
strain); it replaces ``viscoelasticity``, never joins it."""

from __future__ import annotations

from typing import Any

from cell.diagnosis.specimen.causes.base import Parameter, Settings
from cell.diagnosis.specimen.causes.viscoelasticity import Viscoelasticity


class NonlinearViscoelasticity(Viscoelasticity):
    """The relaxation's parameters and the relaxed fraction's slope per unit strain.

    Example:
        >>> from cell.diagnosis.specimen.causes import CandidateMaterial
        >>> NonlinearViscoelasticity().parameters(CandidateMaterial())[-1].name
        'relaxed_fraction_slope'
    """

    name = "nonlinear_viscoelasticity"

    def parameters(self, model: Settings) -> tuple[Parameter, ...]:
        """The relaxation's, then the slope."""
        return (*super().parameters(model), Parameter("relaxed_fraction_slope", 0.0, -10.0, 10.0))

    def fields(self, value: dict[str, float], model: Settings) -> dict[str, Any]:
        """The relaxation's, with the spring law's c from the fitted slope (the fraction
        ``G (1 + c (|x| - x_r))`` has slope ``G c``; 0 when nothing relaxes) at the model's
        reference strain."""
        fraction = value["relaxed_fraction"]
        slope = value["relaxed_fraction_slope"] / fraction if fraction > 0.0 else 0.0
        return {**super().fields(value, model), "relaxation_strain_slope": slope,
                "relaxation_reference_strain": model.reference_strain}
