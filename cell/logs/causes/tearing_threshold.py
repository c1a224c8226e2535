"""``tearing_threshold``: the bindings' tearing stretch (and tearing force) times ``exp(m)``."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from cell.logs.causes.cause import LogCause
from cell.sim.scenario import Scenario


@dataclass(frozen=True)
class TearingThreshold(LogCause):
    """Bindings that tear sooner or later under the pull (docs/logs.md).

    Example:
        >>> world = CAUSE.change(Scenario(), math.log(2.0))
        >>> round(world.aponeurosis.tearing_stretch_m, 6)
        0.02
    """

    def change(self, scenario: Scenario, magnitude: float) -> Scenario:
        """The tearing stretch (m) and tearing force (N) times ``exp(m)``."""
        apo, factor = scenario.aponeurosis, math.exp(magnitude)
        return replace(scenario, aponeurosis=replace(
            apo, tearing_stretch_m=apo.tearing_stretch_m * factor,
            tearing_force_n=apo.tearing_force_n * factor))


CAUSE = TearingThreshold("tearing_threshold", step=0.4)
