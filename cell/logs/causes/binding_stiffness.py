"""``binding_stiffness``: the bindings' stiffness times ``exp(m)``, the seam's toughness kept."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from cell.logs.causes.cause import LogCause
from cell.sim.scenario import Scenario


@dataclass(frozen=True)
class BindingStiffness(LogCause):
    """Bindings that pull back harder or softer for the same stretch, tearing at the same
    stretch and cut as hard (docs/logs.md).

    Example:
        >>> world = CAUSE.change(Scenario(), math.log(2.5))
        >>> round(world.aponeurosis.stiffness_n_m, 6)
        125.0
    """

    def change(self, scenario: Scenario, magnitude: float) -> Scenario:
        """The bindings' stiffness (N/m) times ``exp(m)``."""
        apo = scenario.aponeurosis
        return replace(scenario, aponeurosis=replace(
            apo, stiffness_n_m=apo.stiffness_n_m * math.exp(magnitude)))


CAUSE = BindingStiffness("binding_stiffness", step=0.4)
