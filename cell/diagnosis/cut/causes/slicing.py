"""Slicing: the force to sink the edge falls with the slice/push ratio (``slicing_efficiency``)."""

from __future__ import annotations

from typing import Any

from cell.diagnosis.cut.causes.base import CutCause, CutSettings, Parameter


class Slicing(CutCause):
    """Slicing: the force to sink the edge falls with the slice/push ratio
    (``slicing_efficiency``).

    Example:
        >>> from cell.diagnosis.cut.causes import CutCandidate
        >>> Slicing().parameters(CutCandidate())[0].initial
        1.0
    """

    name = "slicing"
    needs_sliding = True

    def parameters(self, model: CutSettings) -> tuple[Parameter, ...]:
        """Its shape parameters."""
        return (Parameter("slicing_efficiency", 1.0, 0.0, 10.0),)

    def fields(self, value: dict[str, float]) -> dict[str, Any]:
        """The unit cutting model's field it sets."""
        return {"slicing_efficiency": value["slicing_efficiency"]}
