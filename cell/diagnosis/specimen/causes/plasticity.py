"""Plasticity: the yield strain and hardening ratio of every spring."""

from __future__ import annotations

from typing import Any

from cell.diagnosis.specimen.causes.base import Cause, Parameter, Settings


class Plasticity(Cause):
    """Yield strain and hardening ratio.

    Example:
        >>> from cell.diagnosis.specimen.causes import CandidateMaterial
        >>> [p.name for p in Plasticity().parameters(CandidateMaterial())]
        ['yield_strain', 'hardening']
    """

    name = "plasticity"

    def parameters(self, model: Settings) -> tuple[Parameter, ...]:
        """The yield strain and the hardening ratio."""
        return Parameter("yield_strain", 0.03, 0.002, 0.4), Parameter("hardening", 0.3, 0.0, 0.95)

    def fields(self, value: dict[str, float], model: Settings) -> dict[str, Any]:
        """The springs' yield strain and hardening."""
        return {"yield_strain": value["yield_strain"], "hardening": value["hardening"]}
