"""``blade_friction``: the material's face friction (its ``[cutting]`` table) times ``exp(m)``
(a cause of the cut cause table, docs/measured-data.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from cell.logs.causes.cause import LogCause
from cell.sim.scenario import Scenario


@dataclass(frozen=True)
class BladeFriction(LogCause):
    """More or less friction on the blade's faces (docs/measured-data.md).

    Example:
        >>> world = CAUSE.change(Scenario(), math.log(2.0))
        >>> world.material.cutting.face_friction / Scenario().material.cutting.face_friction
        2.0
    """

    def applies(self, scenario: Scenario) -> bool:
        """The cutting model with a face friction to change."""
        cutting = scenario.material.cutting
        return (scenario.aponeurosis.knife_force == "cutting" and cutting is not None
                and bool(cutting.face_friction))

    def change(self, scenario: Scenario, magnitude: float) -> Scenario:
        """The face friction of the material's cutting model times ``exp(m)``."""
        material = scenario.material
        if material.cutting is None:
            return scenario
        cutting = material.cutting
        return replace(scenario, material=replace(material, cutting=replace(
            cutting, face_friction=cutting.face_friction * math.exp(magnitude))))


CAUSE = BladeFriction("blade_friction", step=0.7, table="cut", typical=(1.5, 2.5))
