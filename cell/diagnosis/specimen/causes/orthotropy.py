"""Orthotropy: the sheets' modulus differs from their normal's, E_s / E_n = exp(p), their
geometric mean the material's Et (``MassSpringMaterial.sheet_over_normal``). Only shear and
biaxial tests tell the sheets from their normal, so the search offers it only to sets that
hold them (:attr:`Orthotropy.needs_plane_tests`)."""

from __future__ import annotations

import math
from typing import Any

from cell.diagnosis.specimen.causes.base import Cause, Parameter, Settings

# log(E_s / E_n): 0.30 to 3.3, within what the specimen's cubic lattice reaches (0.24 to 4.2)
# and around the ratios published for myocardium and skeletal muscle (docs/diagnosis.md).
_LOG_RATIO = (-1.2, 1.2)


class Orthotropy(Cause):
    """p = log(E_s / E_n).

    Example:
        >>> from cell.diagnosis.specimen.causes import CandidateMaterial
        >>> [p.name for p in Orthotropy().parameters(CandidateMaterial())]
        ['log_sheet_over_normal']
    """

    name = "orthotropy"
    needs_plane_tests = True

    def parameters(self, model: Settings) -> tuple[Parameter, ...]:
        """p, from transversely isotropic."""
        return (Parameter("log_sheet_over_normal", 0.0, *_LOG_RATIO),)

    def fields(self, value: dict[str, float], model: Settings) -> dict[str, Any]:
        """The material's ``sheet_over_normal``."""
        return {"sheet_over_normal": math.exp(value["log_sheet_over_normal"])}
