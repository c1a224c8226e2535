"""Edge friction: the edge drags along itself with mu_e times its load, turning over the slip
``edge_slip_m`` (``edge_friction_j_m2``, mu_e G, solved in closed form)."""

from __future__ import annotations

from typing import Any

from cell.diagnosis.cut.causes.base import CutCause, CutSettings, Parameter


class EdgeFriction(CutCause):
    """Edge friction: the edge drags along itself with mu_e times its load, turning over the
    slip ``edge_slip_m`` (``edge_friction_j_m2``, mu_e G, solved in closed form).

    Example:
        >>> from cell.diagnosis.cut.causes import CutCandidate
        >>> EdgeFriction().linear(CutCandidate())
        ('edge_friction_j_m2',)
    """

    name = "edge_friction"
    needs_sliding = True

    def parameters(self, model: CutSettings) -> tuple[Parameter, ...]:
        """Its shape parameters."""
        return (Parameter("edge_slip_m", 0.002, 1e-5, 0.5 * model.depth_m),)

    def fields(self, value: dict[str, float]) -> dict[str, Any]:
        """The unit cutting model's field it sets."""
        return {"edge_slip_m": value["edge_slip_m"]}

    def linear(self, model: CutSettings) -> tuple[str, ...]:
        """Its parameters solved in closed form."""
        return ("edge_friction_j_m2",)
