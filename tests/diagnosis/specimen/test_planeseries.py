"""Shear and biaxial tests diagnosed with the uniaxial ones: each is one series of the fit, a
uniaxial set fits as before, and a mixed set's hidden cause is named with its evidence per
mode."""

from pathlib import Path

import numpy as np
import pytest

from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.sets import diagnose_set
from cell.diagnosis.specimen.causes import CandidateMaterial
from cell.diagnosis.specimen.planeseries import PlaneSeries, fitted_series, series_forces
from cell.diagnosis.specimen.report import per_mode_table
from cell.diagnosis.specimen.solve import SpecimenLattice, simulate_tests
from cell.measure.shearbiaxial import BiaxialTest, ShearTest
from cell.measure.specimens import MeasurementSet, MechanicalTest, Specimen, load_measurement_set

CUBE = Specimen("cube", (0.01, 0.01, 0.01))
TIME = np.linspace(0.0, 10.0, 40)


def _shapes() -> list[MechanicalTest | PlaneSeries]:
    """A tissue's tests with zero force: tension along and across the fibres, shear in two
    planes, an equibiaxial stretch."""
    zero = 0.0 * TIME
    return [MechanicalTest("t00", "tension", 0.0, TIME, 1.5e-4 * TIME, zero),
            MechanicalTest("t90", "tension", 90.0, TIME, 1.5e-4 * TIME, zero),
            PlaneSeries(ShearTest("s_fs", "fs", TIME, 2e-4 * TIME, zero, zero), CUBE.size_m),
            PlaneSeries(ShearTest("s_sf", "sf", TIME, 2e-4 * TIME, zero, zero), CUBE.size_m),
            PlaneSeries(BiaxialTest("b11", 0.0, TIME, 1e-4 * TIME, 1e-4 * TIME, zero, zero),
                        CUBE.size_m)]


def _measured(tests: list[MechanicalTest | PlaneSeries], forces: list[np.ndarray],
              folder: Path) -> MeasurementSet:
    """The set whose tests measured ``forces`` (each series' columns one after another)."""
    uniaxial, shear, biaxial = [], [], []
    for test, force in zip(tests, forces, strict=True):
        if isinstance(test, MechanicalTest):
            uniaxial.append(MechanicalTest(test.test_id, test.mode, test.angle_deg, TIME,
                                           test.displacement_m, force))
        elif isinstance(test.test, ShearTest):
            shear.append(ShearTest(test.test_id, test.test.shear_plane, TIME,
                                   test.test.displacement_m, *np.split(force, 2)))
        else:
            biaxial.append(BiaxialTest(test.test_id, 0.0, TIME, test.test.displacement_m,
                                       test.test.displacement_x_m, *np.split(force, 2)))
    return MeasurementSet(folder, CUBE, tuple(uniaxial), shear_tests=tuple(shear),
                          biaxial_tests=tuple(biaxial))


def test_a_shear_or_biaxial_test_is_one_series_of_its_measured_columns() -> None:
    shear, biaxial = _shapes()[2], _shapes()[4]
    assert shear.mode == "shear fs" and biaxial.mode == "biaxial"
    assert shear.columns == ("force_N", "normal_force_N")
    assert biaxial.columns == ("force_N", "force_x_N")
    assert len(shear.force_n) == len(shear.time_s) == len(shear.strain(CUBE)) == 2 * len(TIME)
    thinned = biaxial.subset(np.array([0, 5, 39]))
    np.testing.assert_array_equal(thinned.displacement_m, np.tile(1e-4 * TIME[[0, 5, 39]], 2))
    np.testing.assert_array_equal(thinned.force_n, np.zeros(6))


def test_a_uniaxial_set_is_simulated_as_before() -> None:
    tests = _shapes()[:2]
    material = CandidateMaterial(("anisotropy",)).material(np.array([0.7, 0.0]), 8e3, 1060.0)
    lattice = SpecimenLattice.of(CUBE)
    before = [run.force_n for run in simulate_tests(tests, CUBE, material, lattice)]
    for old, new in zip(before, series_forces(tests, CUBE, material, lattice), strict=True):
        np.testing.assert_array_equal(old, new)


@pytest.mark.slow  # a whole diagnosis
def test_a_mixed_set_names_its_hidden_anisotropy_with_the_evidence_of_each_mode(
        tmp_path: Path) -> None:
    tests = _shapes()
    material = CandidateMaterial(("anisotropy",)).material(np.array([0.9, 0.0]), 8e3, 1060.0)
    forces = series_forces(tests, CUBE, material, SpecimenLattice.of(CUBE))
    noise = 0.01 * max(float(np.abs(f).max()) for f in forces)
    rng = np.random.default_rng(3)
    data = _measured(tests, [f + rng.normal(0.0, noise, len(f)) for f in forces], tmp_path)
    assert [t.test_id for t in fitted_series(data)] == ["t00", "t90", "s_fs", "s_sf", "b11"]

    result = diagnose_set(data, DiagnosisParams(workers=1))

    assert result.causes == ("anisotropy",)
    (evidence,) = result.uniaxial.evidence
    assert evidence.params["log_el_over_et"][0] == pytest.approx(0.9, abs=0.09)
    assert list(evidence.per_mode) == ["tension", "shear fs", "shear sf", "biaxial"]
    assert all(without > with_ for with_, without in evidence.per_mode.values())
    assert evidence.revealed_by == "tension"  # along and across the fibres: the ratio itself
    entry = result.to_json()["evidence"][0]
    assert entry["revealed_by"] == "tension" and set(entry["per_mode"]) == set(evidence.per_mode)
    assert "| anisotropy | biaxial |" in "\n".join(per_mode_table(result.uniaxial.evidence))


def test_a_uniaxial_sets_fitted_series_are_its_tests() -> None:
    data = load_measurement_set("assets/measured/beef_round_example")
    assert all(isinstance(t, MechanicalTest) for t in fitted_series(data))
    assert fitted_series(data) == data.tests
