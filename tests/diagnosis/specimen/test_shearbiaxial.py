"""Simulated shear and biaxial tests: the homogeneous lattice against the lattice's own
small-strain elastic constants, and against the meshed specimen in MuJoCo
(:mod:`tests.shear_reference`) within 2 %."""

import math
from dataclasses import replace

import numpy as np
import pytest

from cell.diagnosis.specimen.shearbiaxial import simulate_biaxial, simulate_shear
from cell.diagnosis.specimen.solve import (
    SpecimenLattice,
    fibre_direction,
    fibre_turn_deg,
    sheet_direction,
    simulate_tests,
    turned,
)
from cell.errors import DivergenceError
from cell.measure.shearbiaxial import SHEAR_PLANES, BiaxialTest, ShearTest
from cell.measure.specimens import MechanicalTest, Specimen
from cell.tissue.material import MassSpringMaterial
from cell.tissue.packedlaw import LATTICE_STIFFENING
from cell.tissue.springlaw import spring_stress
from tests.shear_reference import simulate_gradient
from tests.specimen_reference import SpecimenSimParams

CUBE = Specimen("cube", (0.01, 0.01, 0.01))
ISOTROPIC = MassSpringMaterial.isotropic(1e4, geometric_compensation=LATTICE_STIFFENING)
ANISOTROPIC = MassSpringMaterial.transversely_isotropic(
    2e4, 1e4, geometric_compensation=LATTICE_STIFFENING)
# Sheets twice as stiff as their normal, Et their geometric mean.
ORTHOTROPIC = replace(ISOTROPIC, sheet_over_normal=2.0)
TIME = np.linspace(0.0, 2.0, 41)
# The meshed reference needs an even number of cells: the mirrored split tiles in pairs.
QUICK = SpecimenSimParams(cells=4)
REFERENCE = SpecimenSimParams(cells=8, max_mass_scale=1.0, timestep_safety=0.45)


def _shear(plane: str, gamma: float) -> ShearTest:
    return ShearTest(plane, plane, TIME, gamma * TIME / TIME[-1] * CUBE.size_m[2], 0.0 * TIME)


def _biaxial(angle_deg: float, strain_z: float, strain_x: float) -> BiaxialTest:
    ramp = TIME / TIME[-1]
    return BiaxialTest("b", angle_deg, TIME, strain_z * ramp * CUBE.size_m[2],
                       strain_x * ramp * CUBE.size_m[0], 0.0 * TIME, 0.0 * TIME)


def _turned(material: MassSpringMaterial, turn_deg: float) -> MassSpringMaterial:
    """``material`` with its fibres turned by ``turn_deg`` from x towards z (its sheets)."""
    angle = math.radians(turn_deg)
    return replace(material, fibre_direction=(math.cos(angle), 0.0, math.sin(angle)))


def _elastic_constants(material: MassSpringMaterial, fibre: np.ndarray) -> np.ndarray:
    """The lattice's small-strain stiffness C_ijkl = sum_j w_j k_j n_i n_j n_k n_l, Pa (k_j the
    springs' small-strain modulus along rest direction n_j)."""
    lattice = SpecimenLattice.of(CUBE)
    law = lattice.law(material)
    strain = 1e-9
    n = lattice.parallel_directions
    moduli = np.array([spring_stress(strain, float(c), law.curves, law.params, law.history(1),
                                     0, 0.0, False)[0] / strain for c in (n @ fibre) ** 2])
    return np.einsum("j,ja,jb,jc,jd->abcd", lattice.parallel_weights * moduli, n, n, n, n)


@pytest.mark.parametrize("material", [ISOTROPIC, ANISOTROPIC], ids=["isotropic", "anisotropic"])
@pytest.mark.parametrize("plane", SHEAR_PLANES)
def test_small_shear_stress_is_the_lattice_shear_modulus_times_gamma(
        material: MassSpringMaterial, plane: str) -> None:
    test = _shear(plane, 1e-4)
    run = simulate_shear(test, CUBE, material)
    modulus = _elastic_constants(material, np.eye(3)[test.fibre_axis])[0, 2, 0, 2]
    assert run.force_n["force_N"][-1] / CUBE.area_m2 == pytest.approx(modulus * 1e-4, rel=1e-4)
    # The normal stress of simple shear is second order in gamma.
    assert abs(run.force_n["normal_force_N"][-1]) < 1e-3 * abs(run.force_n["force_N"][-1])


@pytest.mark.parametrize("plane", SHEAR_PLANES)
def test_small_shear_stresses_of_turned_fibres_follow_the_lattice_with_the_fibres_turned(
        plane: str) -> None:
    gamma = 1e-6  # oblique springs strain at first order: their second-order terms apart
    test, material = _shear(plane, gamma), _turned(ANISOTROPIC, 20.0)
    run = simulate_shear(test, CUBE, material)
    fibre, _ = turned(np.eye(3)[test.fibre_axis], np.eye(3)[test.sheet_axis], 20.0)
    c = _elastic_constants(material, fibre) * gamma
    assert run.force_n["force_N"][-1] / CUBE.area_m2 == pytest.approx(c[0, 2, 0, 2], rel=1e-4)
    # Fibres oblique in the sheared plane load the plates' normal at first order in gamma.
    assert run.force_n["normal_force_N"][-1] / CUBE.area_m2 == pytest.approx(
        c[2, 2, 0, 2], rel=1e-3, abs=1e-4 * c[0, 2, 0, 2])


def test_a_turn_is_about_the_sheets_normal_the_fibres_towards_the_sheets_in_every_test() -> None:
    material = replace(ANISOTROPIC, sheet_over_normal=2.0)

    def shear(plane: str, turn_deg: float) -> dict[str, np.ndarray]:
        return simulate_shear(_shear(plane, 0.2), CUBE, _turned(material, turn_deg)).force_n

    assert fibre_turn_deg(_turned(material, -25.0)) == pytest.approx(-25.0)
    # sf's fibres turned by 25 degrees lie where fs's turned by 65 do, and so do the sheets.
    for name, force in shear("sf", 25.0).items():
        np.testing.assert_allclose(force, shear("fs", 65.0)[name], rtol=1e-9)
    # y mirrors fn's shear: either way of turning is alike; in fs's plane the normal force tells
    # the two apart (the fibres stretched by the shear, or squeezed).
    np.testing.assert_allclose(shear("fn", 25.0)["force_N"], shear("fn", -25.0)["force_N"],
                               rtol=1e-9)
    assert shear("fs", 25.0)["normal_force_N"][-1] > 1.2 * shear("fs", -25.0)["normal_force_N"][-1]
    # A tension test at 30 degrees of fibres turned by 25 is one at 55 of the declared fibres.
    tension = [MechanicalTest(f"t{a}", "tension", a, TIME, 1e-3 * TIME, 0.0 * TIME)
               for a in (30.0, 55.0)]
    np.testing.assert_array_equal(simulate_tests(tension[:1], CUBE, _turned(material, 25.0))[0]
                                  .force_n, simulate_tests(tension[1:], CUBE, material)[0].force_n)
    biaxial = simulate_biaxial(_biaxial(10.0, 0.05, 0.02), CUBE, _turned(material, 20.0))
    np.testing.assert_array_equal(biaxial.force_n["force_N"], simulate_biaxial(
        _biaxial(30.0, 0.05, 0.02), CUBE, material).force_n["force_N"])


def test_the_shear_modes_pair_up_in_a_transversely_isotropic_material() -> None:
    forces = {plane: simulate_shear(_shear(plane, 0.2), CUBE, ANISOTROPIC).force_n["force_N"]
              for plane in SHEAR_PLANES}
    for one, other in (("fs", "fn"), ("sf", "nf"), ("sn", "ns")):
        np.testing.assert_allclose(forces[one], forces[other], rtol=1e-9)
    assert forces["fs"][-1] != pytest.approx(forces["sn"][-1], rel=0.05)


def test_an_orthotropic_material_parts_the_shear_modes_and_the_biaxial_forces() -> None:
    shear = {plane: simulate_shear(_shear(plane, 1e-3), CUBE, ORTHOTROPIC).force_n["force_N"][-1]
             for plane in SHEAR_PLANES}
    # Shearing towards the stiffer sheets takes more force, by less than their ratio: the
    # lattice's shear modulus is not its Young's modulus.
    assert 1.2 < shear["fs"] / shear["fn"] < 2.0
    assert shear["sf"] == pytest.approx(shear["fs"], rel=1e-4)  # the same plane, either way
    assert shear["sn"] == pytest.approx(shear["ns"], rel=1e-4)
    isotropic = simulate_shear(_shear("fs", 1e-3), CUBE, ISOTROPIC).force_n["force_N"][-1]
    assert shear["fn"] < isotropic < shear["fs"]
    # Equibiaxial: the fibres keep Et's stiffness, the sheets across them sqrt(2) times it.
    run = simulate_biaxial(_biaxial(0.0, 1e-4, 1e-4), CUBE, ORTHOTROPIC)
    plain = simulate_biaxial(_biaxial(0.0, 1e-4, 1e-4), CUBE, ISOTROPIC)
    assert run.force_n["force_x_N"][-1] > 1.2 * plain.force_n["force_x_N"][-1]


def test_the_lattice_has_the_orthotropic_materials_young_moduli() -> None:
    tension = MechanicalTest("t", "tension", 90.0, TIME, 1e-6 * TIME, 0.0 * TIME)
    (run,) = simulate_tests([tension], CUBE, ORTHOTROPIC)  # along the sheets (x, at 90 deg)
    strain = 1e-6 * TIME[-1] / CUBE.size_m[2]
    assert run.force_n[-1] / CUBE.area_m2 / strain == pytest.approx(1e4 * 2**0.5, rel=1e-3)
    lattice = SpecimenLattice.of(CUBE)
    assert lattice.sheet_factor(ISOTROPIC) == 1.0 and lattice.sheet_factor(ORTHOTROPIC) > 1.0


@pytest.mark.parametrize(("strain_z", "strain_x"), [(1e-4, 1e-4), (1e-4, 0.5e-4), (0.5e-4, 1e-4)])
def test_small_biaxial_stresses_follow_the_lattice_with_a_free_thickness(
        strain_z: float, strain_x: float) -> None:
    run = simulate_biaxial(_biaxial(0.0, strain_z, strain_x), CUBE, ANISOTROPIC)
    c = _elastic_constants(ANISOTROPIC, np.asarray(fibre_direction(0.0)))
    strain_y = -(c[1, 1, 0, 0] * strain_x + c[1, 1, 2, 2] * strain_z) / c[1, 1, 1, 1]
    stress_z = c[2, 2, 0, 0] * strain_x + c[2, 2, 1, 1] * strain_y + c[2, 2, 2, 2] * strain_z
    stress_x = c[0, 0, 0, 0] * strain_x + c[0, 0, 1, 1] * strain_y + c[0, 0, 2, 2] * strain_z
    assert run.gradient[-1, 1] - 1.0 == pytest.approx(strain_y, rel=1e-3)
    assert run.force_n["force_N"][-1] / CUBE.area_m2 == pytest.approx(stress_z, rel=1e-3)
    assert run.force_n["force_x_N"][-1] / CUBE.area_m2 == pytest.approx(stress_x, rel=1e-3)


def test_oblique_fibres_shear_a_biaxial_sheet_in_its_plane() -> None:
    run = simulate_biaxial(_biaxial(30.0, 0.1, 0.05), CUBE, ANISOTROPIC)
    assert abs(run.gradient[-1, 3]) > 0.01
    assert abs(simulate_biaxial(_biaxial(0.0, 0.1, 0.05), CUBE, ANISOTROPIC).gradient[-1, 3]) \
        < 1e-12


def test_a_collapsed_sheet_is_a_divergence_naming_the_test() -> None:
    with pytest.raises(DivergenceError, match=r"'b'.*no equilibrium"):
        simulate_biaxial(_biaxial(0.0, -1.0, -1.0), CUBE, ISOTROPIC)


def _against_mesh(test: ShearTest | BiaxialTest, material: MassSpringMaterial,
                  params: SpecimenSimParams) -> dict[str, float]:
    """The largest difference of each force to the meshed reference's, over its largest (the
    meshed springs calibrated along z, their sheets where the test puts them)."""
    path = np.zeros((len(TIME), 4))
    if isinstance(test, ShearTest):
        fast = simulate_shear(test, CUBE, material)
        path[:, 3] = test.gamma(CUBE.size_m)
        fibre, sheet = turned(np.eye(3)[test.fibre_axis], np.eye(3)[test.sheet_axis],
                              fibre_turn_deg(material))
        meshed_material = replace(material, fibre_direction=tuple(fibre),
                                  sheet_direction=tuple(sheet))
        mesh = simulate_gradient(CUBE, meshed_material, fibre, TIME, path, True, params)
        meshed = {"force_N": mesh.top_N[:, 0], "normal_force_N": mesh.top_N[:, 1]}
    else:
        fast = simulate_biaxial(test, CUBE, material)
        path[:, 2], path[:, 0] = test.strains(CUBE.size_m).T
        angle = test.angle_deg + fibre_turn_deg(material)
        meshed_material = replace(material, fibre_direction=fibre_direction(angle),
                                  sheet_direction=sheet_direction(angle))
        mesh = simulate_gradient(CUBE, meshed_material, fibre_direction(angle), TIME, path,
                                 False, params)
        meshed = {"force_N": mesh.top_N[:, 1], "force_x_N": mesh.side_N[:, 0]}
    return {name: float(np.abs(fast.force_n[name] - force).max() / np.abs(force).max())
            for name, force in meshed.items()}


CASES = [
    pytest.param(_shear("fs", 0.1), ISOTROPIC, id="shear fs isotropic"),
    pytest.param(_shear("fs", 0.1), ANISOTROPIC, id="shear fs"),
    pytest.param(_shear("sf", 0.1), ANISOTROPIC, id="shear sf"),
    pytest.param(_shear("sn", 0.1), ANISOTROPIC, id="shear sn"),
    pytest.param(_biaxial(0.0, 0.05, 0.05), ANISOTROPIC, id="biaxial 1:1"),
    pytest.param(_biaxial(0.0, 0.05, 0.025), ANISOTROPIC, id="biaxial 1:0.5"),
    pytest.param(_biaxial(90.0, 0.025, 0.05), ISOTROPIC, id="biaxial 0.5:1 across"),
    # Orthotropic, fibres along z (the meshed springs' calibration axis): sheets along x, y.
    pytest.param(_shear("fs", 0.1), ORTHOTROPIC, id="shear fs orthotropic"),
    pytest.param(_shear("fn", 0.1), ORTHOTROPIC, id="shear fn orthotropic"),
    pytest.param(_biaxial(0.0, 0.05, 0.025), ORTHOTROPIC, id="biaxial 1:0.5 orthotropic"),
    # Fibres turned 20 degrees towards the sheets: out of the x-z plane in fn.
    pytest.param(_shear("fs", 0.1), _turned(ANISOTROPIC, 20.0), id="shear fs turned"),
    pytest.param(_shear("fn", 0.1), _turned(ANISOTROPIC, 20.0), id="shear fn turned"),
]


@pytest.mark.parametrize(("test", "material"), CASES)
def test_the_homogeneous_solve_is_within_two_percent_of_a_small_meshed_specimen(
        test: ShearTest | BiaxialTest, material: MassSpringMaterial) -> None:
    errors = _against_mesh(test, material, QUICK)
    assert max(errors.values()) < 0.02, errors


# Each run of the fine reference takes 15-35 s.
@pytest.mark.slow
@pytest.mark.parametrize(("test", "material"), CASES)
def test_the_homogeneous_solve_is_within_two_percent_of_the_fine_slow_reference(
        test: ShearTest | BiaxialTest, material: MassSpringMaterial) -> None:
    errors = _against_mesh(test, material, REFERENCE)
    assert max(errors.values()) < 0.02, errors
