"""Indentation stiffness: the edge force ramps in over the first ``indentation_depth_m``."""

from __future__ import annotations

from typing import Any

from cell.diagnosis.cut.causes.base import CutCause, CutSettings, Parameter


class IndentationStiffness(CutCause):
    """Indentation stiffness: the edge force ramps in over the first ``indentation_depth_m``.

    Example:
        >>> from cell.diagnosis.cut.causes import CutCandidate
        >>> IndentationStiffness().parameters(CutCandidate(depth_m=0.03))[0].high
        0.015
    """

    name = "indentation_stiffness"

    def parameters(self, model: CutSettings) -> tuple[Parameter, ...]:
        """Its shape parameters."""
        return (Parameter("indentation_depth_m", 0.1 * model.depth_m, 1e-5, 0.5 * model.depth_m),)

    def fields(self, value: dict[str, float]) -> dict[str, Any]:
        """The unit cutting model's field it sets."""
        return {"indentation_depth_m": value["indentation_depth_m"]}
