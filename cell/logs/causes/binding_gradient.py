"""``binding_gradient``: the seam's toughness graded along the interface, ``exp(m)`` the ratio
of its two ends (the scenario's ``aponeurosis.toughness_gradient``, docs/scenarios.md)."""

from __future__ import annotations

from dataclasses import dataclass, replace

from cell.logs.causes.cause import LogCause
from cell.sim.scenario import Scenario


@dataclass(frozen=True)
class BindingGradient(LogCause):
    """An aponeurosis tougher toward one end of the interface (docs/logs.md).

    Example:
        >>> CAUSE.change(Scenario(), 0.5).aponeurosis.toughness_gradient
        0.5
    """

    def applies(self, scenario: Scenario) -> bool:
        """Only the cutting model has a seam whose toughness can be graded."""
        return scenario.aponeurosis.knife_force == "cutting"

    def change(self, scenario: Scenario, magnitude: float) -> Scenario:
        """The seam's toughness times ``exp(m (x - x_mid) / L)`` along the interface, on top
        of the scenario's own gradient."""
        apo = scenario.aponeurosis
        return replace(scenario, aponeurosis=replace(
            apo, toughness_gradient=apo.toughness_gradient + magnitude))


CAUSE = BindingGradient("binding_gradient", step=0.6, typical=(1.6, 2.5))
