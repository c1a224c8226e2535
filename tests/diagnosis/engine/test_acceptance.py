"""Whether a cause earns its place: non-linear viscoelasticity in place of the quasi-linear kind
is judged on the ramp-and-hold tests alone, the fibres' turn on the shear tests alone, each
against the noise of the tests it is judged on; everything else on every test."""

from __future__ import annotations

from typing import Any

import numpy as np

from cell.diagnosis.engine.acceptance import accepts
from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.specimen.causes import CandidateMaterial
from cell.diagnosis.specimen.fitting import ModelFit
from cell.diagnosis.specimen.search import SpecimenSearch
from cell.measure.shearbiaxial import ShearTest
from cell.measure.specimens import MechanicalTest
from cell.tissue.material import MassSpringMaterial

_TIME = np.linspace(0.0, 10.0, 50)
TESTS = (
    MechanicalTest("ramp", "tension", 0.0, _TIME, 1e-5 * _TIME, np.sin(_TIME)),
    MechanicalTest("hold", "relaxation", 0.0, _TIME, np.full(50, 1e-4), np.cos(_TIME)),
)
NOISE_N = 0.01


def _later_accepts(richer: ModelFit, poorer: ModelFit, tests: tuple[Any, ...],
                   noise_n: float = NOISE_N) -> bool:
    """Whether ``richer`` earns a later cause beside ``poorer`` under the specimen's rules."""
    return accepts(richer, poorer, first=False, noise=noise_n, tests=tests,
                   params=DiagnosisParams(workers=1), rules=SpecimenSearch.rules)


def _fit(causes: tuple[str, ...], first_error_n: float, second_error_n: float,
         bic: float, tests: tuple[Any, ...] = TESTS) -> ModelFit:
    """A fit of two ``tests`` whose held-out predictions miss each by the given constant, N."""
    heldout = (tests[0].force_n + first_error_n, tests[1].force_n + second_error_n)
    rmse = float(np.sqrt((first_error_n**2 + second_error_n**2) / 2.0))
    return ModelFit(CandidateMaterial(causes), np.zeros(0), np.zeros((0, 2)), 1e4, 0.0,
                    MassSpringMaterial(), rmse_n=rmse, heldout_rmse_n=rmse, bic=bic,
                    fitted_force_n=heldout, heldout_force_n=heldout)


def test_a_non_linear_relaxation_is_judged_on_the_holds_alone() -> None:
    # Better on the hold, slightly worse on the ramp (its slope trades misfit there): overall
    # its held-out error is 0.77 of the quasi-linear one's, above the 0.75 a later cause needs.
    quasi = _fit(("plasticity", "viscoelasticity"), 0.05, 0.10, bic=0.0)
    non_linear = _fit(("plasticity", "nonlinear_viscoelasticity"), 0.07, 0.05, bic=-10.0)
    params = DiagnosisParams(workers=1)
    assert non_linear.heldout_rmse_n > params.later_rmse_ratio * quasi.heldout_rmse_n
    assert _later_accepts(non_linear, quasi, TESTS)


def test_a_cause_added_beside_the_non_linearity_is_judged_on_every_test() -> None:
    quasi = _fit(("viscoelasticity",), 0.05, 0.10, bic=0.0)
    with_stiffening = _fit(("strain_stiffening", "nonlinear_viscoelasticity"), 0.07, 0.05,
                           bic=-10.0)
    assert not _later_accepts(with_stiffening, quasi, TESTS)


def test_without_holds_the_non_linearity_is_judged_on_every_test() -> None:
    ramps = (TESTS[0], MechanicalTest("ramp2", "compression", 0.0, _TIME, -1e-5 * _TIME,
                                      np.cos(_TIME)))
    quasi = _fit(("viscoelasticity",), 0.05, 0.10, bic=0.0)
    non_linear = _fit(("nonlinear_viscoelasticity",), 0.07, 0.05, bic=-10.0)
    assert not _later_accepts(non_linear, quasi, ramps)


_RNG = np.random.default_rng(0)
#: A tension test whose force carries noise of 0.05 N and a shear test whose force carries 0.005
#: N (smaller forces, the same relative noise): the set's noise is the tension's.
NOISY = (
    MechanicalTest("t00", "tension", 0.0, _TIME, 1e-5 * _TIME,
                   np.sin(_TIME) + _RNG.normal(0.0, 0.05, 50)),
    ShearTest("fs", "fs", _TIME, 1e-5 * _TIME, 0.1 * np.sin(_TIME) + _RNG.normal(0.0, 0.005, 50),
              None),
)



def test_a_fibre_turn_is_judged_on_the_shear_tests_against_their_noise() -> None:
    # The turn removes a 0.02 N misfit of the shear test: far more than its own noise's
    # variance, far less than the tension's, and nothing on the tension test.
    orthotropic = _fit(("orthotropy",), 0.0, 0.02, bic=0.0, tests=NOISY)
    turned = _fit(("orthotropy", "fibre_direction"), 0.0, 0.001, bic=-10.0, tests=NOISY)
    assert _later_accepts(turned, orthotropic, NOISY, noise_n=0.05)


def test_another_cause_with_the_same_misfits_is_judged_on_every_test() -> None:
    orthotropic = _fit(("orthotropy",), 0.0, 0.02, bic=0.0, tests=NOISY)
    anisotropic = _fit(("orthotropy", "anisotropy"), 0.0, 0.001, bic=-10.0, tests=NOISY)
    assert not _later_accepts(anisotropic, orthotropic, NOISY, noise_n=0.05)
