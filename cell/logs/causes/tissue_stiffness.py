"""``tissue_stiffness``: the material's moduli times ``exp(m)``."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from cell.logs.causes.cause import LogCause
from cell.sim.scenario import Scenario
from cell.tissue.material import ContinuumMaterial

_CURVES = ("longitudinal", "transverse", "longitudinal_compression", "transverse_compression")


@dataclass(frozen=True)
class TissueStiffness(LogCause):
    """Stiffer or softer muscle (docs/logs.md).

    Example:
        >>> CAUSE.change(Scenario(), math.log(2.0)).material.longitudinal.coefficients[0] > 0
        True
    """

    def change(self, scenario: Scenario, magnitude: float) -> Scenario:
        """A continuum material's Young's modulus, or every modulus curve of a mass-spring
        one, times ``exp(m)``."""
        return replace(scenario, material=_stiffer(scenario.material, math.exp(magnitude)))


def _stiffer(material: Any, factor: float) -> Any:
    if isinstance(material, ContinuumMaterial):
        return replace(material, young_pa=material.young_pa * factor)
    curves = {name: replace(curve, coefficients=tuple(c * factor for c in curve.coefficients))
              for name in _CURVES if (curve := getattr(material, name)) is not None}
    return replace(material, **curves)


CAUSE = TissueStiffness("tissue_stiffness", step=0.3, typical=(1.25, 1.6))
