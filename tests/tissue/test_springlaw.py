"""The spring law's tangent: the derivative the implicit step's matrix and its linearised
springs between two runs of the law rest on."""

from __future__ import annotations

import numpy as np
import pytest

from cell.tissue.curves import ModulusCurve
from cell.tissue.material import MassSpringMaterial, default_meat
from cell.tissue.packedlaw import SpringLaw
from cell.tissue.springlaw import spring_stress

_POLYNOMIAL = ModulusCurve((3e4, 1e5, 2e5, 5e5, 0.0, 0.0), r_min=0.8, r_max=1.25)
_MATERIALS = {
    "default meat (exponential curves)": default_meat(),
    "polynomial, clamped outside its range": MassSpringMaterial(
        longitudinal=_POLYNOMIAL, transverse=ModulusCurve.constant(2e4),
        geometric_compensation=0.33, oblique=0.4),
    "relaxing, non-linear share": MassSpringMaterial.isotropic(
        3e4, relaxation_weights=(0.3, 0.2), relaxation_times_s=(0.05, 1.0),
        relaxation_strain_slope=-2.0, relaxation_reference_strain=0.05),
    "plastic, hardening": MassSpringMaterial(
        longitudinal=_POLYNOMIAL, transverse=_POLYNOMIAL, yield_strain=0.04, hardening=0.3),
}


def _stress(law: SpringLaw, history: np.ndarray, x: float, cos_sq: float,
            timestep_s: float) -> tuple[float, float]:
    stress, _, slope = spring_stress(x, cos_sq, law.curves, law.params, history, 0,
                                     timestep_s, False, True)
    return stress, slope


@pytest.mark.parametrize("name", list(_MATERIALS))
def test_tangent_is_the_derivative_of_the_stress(name: str) -> None:
    # Strains across both curves' ranges and beyond them, fibres at every angle, from a
    # history that has relaxed and flowed: the tangent matches a central difference.
    law = SpringLaw.of(_MATERIALS[name])
    rng = np.random.default_rng(3)
    history = law.history(1)
    for x in np.linspace(-0.3, 0.4, 15):  # load the history along a path first
        spring_stress(float(x), 0.5, law.curves, law.params, history, 0, 0.01, True)
    step = 1e-6
    for x in np.concatenate([np.linspace(-0.35, 0.45, 41), rng.uniform(-0.3, 0.4, 40)]):
        cos_sq = float(rng.uniform())
        up, _ = _stress(law, history, x + step, cos_sq, 0.005)
        down, _ = _stress(law, history, x - step, cos_sq, 0.005)
        _, slope = _stress(law, history, x, cos_sq, 0.005)
        scale = max(abs(slope), 1e-3 * law.curves[0, 0])
        assert slope == pytest.approx((up - down) / (2.0 * step), abs=1e-5 * scale), x
