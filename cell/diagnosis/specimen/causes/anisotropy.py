"""Anisotropy: El = E exp(q / 2) along the fibres, Et = E exp(-q / 2), the oblique springs'
factor, and both apart in compression (tissue's anisotropy differs there, and so does the
lattice's)."""

from __future__ import annotations

from typing import Any

from cell.diagnosis.specimen.causes.base import Cause, Parameter, Settings

_RATIO = (-1.6, 1.6)
_OBLIQUE = (-0.8, 3.0)


class Anisotropy(Cause):
    """q = log(El / Et) and, where the model has it, the oblique factor; each again in
    compression.

    Example:
        >>> from cell.diagnosis.specimen.causes import CandidateMaterial
        >>> [p.name for p in Anisotropy().parameters(CandidateMaterial())]
        ['log_el_over_et', 'log_el_over_et_compressed']
    """

    name = "anisotropy"

    def parameters(self, model: Settings) -> tuple[Parameter, ...]:
        """q (and the oblique factor), then the same in compression."""
        ratio = Parameter("log_el_over_et", 0.0, *_RATIO)
        oblique = Parameter("oblique", 0.0, *_OBLIQUE)
        ratio_c = Parameter("log_el_over_et_compressed", 0.0, *_RATIO)
        oblique_c = Parameter("oblique_compressed", 0.0, *_OBLIQUE)
        if model.oblique:
            return ratio, oblique, ratio_c, oblique_c
        return ratio, ratio_c

    def fields(self, value: dict[str, float], model: Settings) -> dict[str, Any]:
        """The oblique springs' factor, in tension and in compression."""
        return {"oblique": value.get("oblique", 0.0),
                "oblique_compression": value.get("oblique_compressed")}
