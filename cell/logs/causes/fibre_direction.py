"""``fibre_direction``: the fibres turned about the vertical by ``m`` rad."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from cell.logs.causes.cause import LogCause
from cell.sim.scenario import Scenario
from cell.tissue.material import MassSpringMaterial


@dataclass(frozen=True)
class FibreDirection(LogCause):
    """Fibres that run otherwise than the lab believes (docs/logs.md).

    Example:
        >>> turned = CAUSE.change(Scenario(), math.pi / 2).material.fibre_direction
        >>> [round(v, 6) + 0.0 for v in turned]
        [0.0, 1.0, 0.0]
    """

    def applies(self, scenario: Scenario) -> bool:
        """Only a mass-spring material has a fibre direction."""
        return isinstance(scenario.material, MassSpringMaterial)

    def change(self, scenario: Scenario, magnitude: float) -> Scenario:
        """The material's fibre direction turned about the world's z by ``magnitude`` rad."""
        material = scenario.material
        if not isinstance(material, MassSpringMaterial):
            return scenario
        turn = np.array([[math.cos(magnitude), -math.sin(magnitude), 0.0],
                         [math.sin(magnitude), math.cos(magnitude), 0.0], [0.0, 0.0, 1.0]])
        return replace(scenario, material=replace(material, fibre_direction=tuple(
            (turn @ np.asarray(material.fibre_direction)).tolist())))


CAUSE = FibreDirection("fibre_direction", step=0.6, kind="angle", typical=(20.0, 60.0))
