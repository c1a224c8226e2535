"""Layered toughness: the toughness changes at depths below the top face
(``layer_depth_{k}_m``), one toughness per layer solved in closed form (the first is the
baseline's)."""

from __future__ import annotations

from cell.diagnosis.cut.causes.base import CutCause, CutSettings, Parameter


class LayeredToughness(CutCause):
    """Layered toughness: the toughness changes at depths below the top face
    (``layer_depth_{k}_m``), one toughness per layer solved in closed form (the first is the
    baseline's).

    Example:
        >>> from cell.diagnosis.cut.causes import CutCandidate
        >>> LayeredToughness().linear(CutCandidate(layers=3))
        ('toughness_1_j_m2', 'toughness_2_j_m2')
    """

    name = "layered_toughness"
    column = 0

    def parameters(self, model: CutSettings) -> tuple[Parameter, ...]:
        """Its shape parameters."""
        return tuple(Parameter(f"layer_depth_{k}_m", model.depth_m * (k + 1) / model.layers,
                               0.02 * model.depth_m, 0.98 * model.depth_m)
                     for k in range(model.layers - 1))

    def linear(self, model: CutSettings) -> tuple[str, ...]:
        """Its parameters solved in closed form."""
        return tuple(f"toughness_{k}_j_m2" for k in range(1, model.layers))
