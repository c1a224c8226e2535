"""Edge loading: the edge loads the material over ``loading_depth_m`` past the crack front
before the crack runs; the load holds while the edge rests."""

from __future__ import annotations

from typing import Any

from cell.diagnosis.cut.causes.base import CutCause, CutSettings, Parameter


class EdgeLoading(CutCause):
    """Edge loading: the edge loads the material over ``loading_depth_m`` past the crack front
    before the crack runs; the load holds while the edge rests.

    Example:
        >>> from cell.diagnosis.cut.causes import CutCandidate
        >>> EdgeLoading().parameters(CutCandidate())[0].name
        'loading_depth_m'
    """

    name = "edge_loading"

    def parameters(self, model: CutSettings) -> tuple[Parameter, ...]:
        """Its shape parameters."""
        return (Parameter("loading_depth_m", 0.1 * model.depth_m, 1e-5, 0.5 * model.depth_m),)

    def fields(self, value: dict[str, float]) -> dict[str, Any]:
        """The unit cutting model's field it sets."""
        return {"loading_depth_m": value["loading_depth_m"]}
