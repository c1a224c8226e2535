"""Rate-dependent cutting: the toughness times ``(v / v_ref)^m`` (``rate_exponent``)."""

from __future__ import annotations

from typing import Any

from cell.diagnosis.cut.causes.base import CutCause, CutSettings, Parameter


class RateDependentCutting(CutCause):
    """Rate-dependent cutting: the toughness times ``(v / v_ref)^m`` (``rate_exponent``).

    Example:
        >>> from cell.diagnosis.cut.causes import CutCandidate
        >>> RateDependentCutting().parameters(CutCandidate())[0].name
        'rate_exponent'
    """

    name = "rate_dependent_cutting"

    def parameters(self, model: CutSettings) -> tuple[Parameter, ...]:
        """Its shape parameters."""
        return (Parameter("rate_exponent", 0.0, -1.0, 1.0),)

    def fields(self, value: dict[str, float]) -> dict[str, Any]:
        """The unit cutting model's field it sets."""
        return {"rate_exponent": value["rate_exponent"]}
