"""``binding_strength``: the seam's toughness and the bindings' stiffness times ``exp(m)``."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from cell.logs.causes.cause import LogCause
from cell.sim.scenario import Scenario


@dataclass(frozen=True)
class BindingStrength(LogCause):
    """A stronger or weaker aponeurosis (docs/logs.md).

    Example:
        >>> world = CAUSE.change(Scenario(), math.log(2.0))
        >>> world.aponeurosis.stiffness_n_m
        100.0
    """

    def change(self, scenario: Scenario, magnitude: float) -> Scenario:
        """The seam's toughness (J/m^2) and the bindings' stiffness (N/m) times ``exp(m)``."""
        apo, factor = scenario.aponeurosis, math.exp(magnitude)
        return replace(scenario, aponeurosis=replace(
            apo, toughness_j_m2=apo.toughness_j_m2 * factor,
            stiffness_n_m=apo.stiffness_n_m * factor))


CAUSE = BindingStrength("binding_strength", step=0.4)
