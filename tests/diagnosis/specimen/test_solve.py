"""Simulated specimen tests: the quasi-static lattice against closed forms, each part of the
spring law, and against the fine, slow reference (the meshed specimen in MuJoCo)."""

import pickle
from dataclasses import replace

import numpy as np
import pytest

from cell.diagnosis.specimen.solve import (
    SpecimenLattice,
    fibre_direction,
    simulate_set,
    simulate_test,
    simulate_tests,
    specimen_mesh,
)
from cell.errors import DivergenceError
from cell.measure.specimens import MechanicalTest, Specimen, load_measurement_set
from cell.tissue.curves import ModulusCurve
from cell.tissue.material import MassSpringMaterial
from cell.tissue.packedlaw import LATTICE_STIFFENING
from tests.paths import EXAMPLE_SET
from tests.specimen_reference import SpecimenSimParams, simulate_meshed

EXAMPLE = EXAMPLE_SET
CUBE = Specimen("cube", (0.01, 0.01, 0.01))
# Springs as the diagnosis fits them: the lattice's geometric stiffening compensated.
ISOTROPIC = MassSpringMaterial.isotropic(1e4, geometric_compensation=LATTICE_STIFFENING)
ANISOTROPIC = MassSpringMaterial.transversely_isotropic(
    2e4, 1e4, geometric_compensation=LATTICE_STIFFENING)
# Fine and slow: 8 cells per edge, the real mass, half the stable step.
REFERENCE = SpecimenSimParams(cells=8, max_mass_scale=1.0, timestep_safety=0.45)


def _test(angle_deg: float, time_s: np.ndarray, strain: np.ndarray,
          mode: str = "tension") -> MechanicalTest:
    return MechanicalTest("t", mode, angle_deg, time_s, strain * CUBE.size_m[2],
                          np.zeros_like(time_s))


def _ramp(angle_deg: float, strain: float, duration_s: float = 2.0, samples: int = 40,
          hold_s: float = 0.0) -> MechanicalTest:
    """A ramp from rest to ``strain`` over ``duration_s``, then held for ``hold_s``."""
    t = np.linspace(0.0, duration_s, samples)
    path = strain * t / duration_s
    if hold_s:
        held = duration_s + np.linspace(0.0, hold_s, samples)[1:]
        t, path = np.r_[t, held], np.r_[path, np.full(samples - 1, strain)]
    return _test(angle_deg, t, path, "relaxation" if hold_s else "tension")


def _cycle(angle_deg: float, amplitude: float, duration_s: float) -> MechanicalTest:
    """Load to ``amplitude`` and back to zero displacement."""
    t = np.linspace(0.0, duration_s, 81)
    return _test(angle_deg, t, amplitude * (1.0 - np.abs(1.0 - 2.0 * t / duration_s)), "cyclic")


def _secant_pa(test: MechanicalTest, material: MassSpringMaterial) -> float:
    run = simulate_test(test, CUBE, material)
    return float(run.force_n[-1] / CUBE.area_m2 / test.strain(CUBE)[-1])


def test_mesh_spans_the_specimen_and_fibres_turn_in_the_xz_plane() -> None:
    mesh = specimen_mesh(Specimen("slab", (0.02, 0.01, 0.005)), 4)
    np.testing.assert_allclose(mesh.points.max(axis=0), (0.02, 0.01, 0.005))
    assert len(mesh.tets) == 6 * 4 * 2 * 1
    np.testing.assert_allclose(fibre_direction(0.0), (0.0, 0.0, 1.0))
    np.testing.assert_allclose(fibre_direction(45.0), (0.5**0.5, 0.0, 0.5**0.5))


def test_small_strain_moduli_are_the_materials() -> None:
    assert _secant_pa(_ramp(0.0, 0.001), ISOTROPIC) == pytest.approx(1e4, rel=1e-3)
    assert _secant_pa(_ramp(0.0, 0.001), ANISOTROPIC) == pytest.approx(2e4, rel=1e-3)
    assert _secant_pa(_ramp(90.0, 0.001), ANISOTROPIC) == pytest.approx(1e4, rel=1e-3)


@pytest.mark.parametrize("angle_deg", [30.0, 45.0, 90.0])
def test_an_isotropic_material_does_not_depend_on_the_fibre_angle(angle_deg: float) -> None:
    for strain in (0.15, -0.2):
        assert _secant_pa(_ramp(angle_deg, strain), ISOTROPIC) == pytest.approx(
            _secant_pa(_ramp(0.0, strain), ISOTROPIC), rel=1e-9)


@pytest.mark.parametrize("strain", [-0.3, -0.15, 0.1, 0.25])
def test_compensated_linear_springs_give_a_linear_nominal_curve(strain: float) -> None:
    assert _secant_pa(_ramp(0.0, strain), ISOTROPIC) == pytest.approx(1e4, rel=0.005)
    plain = MassSpringMaterial.isotropic(1e4)
    assert _secant_pa(_ramp(0.0, strain), plain) == pytest.approx(1e4 * (1 + 0.28 * strain),
                                                                 rel=0.01)


def test_stiffening_curve_is_followed_along_the_load_as_far_as_a_lattice_can() -> None:
    # Springs off the load axis see less than the load's strain, so a lattice stiffens less
    # than its springs' curve (3.3-fold here at 15%): fits find the lattice's own exponent.
    curve = ModulusCurve.exponential(1e4, 8.0, 0.6, 1.4)
    material = MassSpringMaterial(longitudinal=curve, transverse=curve,
                                  geometric_compensation=LATTICE_STIFFENING)
    for strain in (0.15, -0.2):
        expected = float(curve.stress_pa(1.0 + strain)) / strain
        secant = _secant_pa(_ramp(0.0, strain), material)
        assert 0.85 * expected < secant < expected


def test_compression_curves_set_the_compressive_modulus() -> None:
    material = replace(ISOTROPIC, longitudinal_compression=ModulusCurve.constant(4e3),
                       transverse_compression=ModulusCurve.constant(4e3))
    # The springs across the load shorten in tension and lengthen in compression (Poisson):
    # they soften the one and stiffen the other a little.
    assert _secant_pa(_ramp(0.0, -0.001), material) == pytest.approx(4e3, rel=0.05)
    assert _secant_pa(_ramp(0.0, 0.001), material) == pytest.approx(1e4, rel=0.07)


def test_a_compression_oblique_factor_acts_at_mid_angles_in_compression() -> None:
    oblique = replace(ANISOTROPIC, oblique=-0.5)
    apart = replace(oblique, oblique_compression=0.5)
    # The lattice is calibrated in compression with its own factor, so along and across the
    # fibres it keeps El and Et (within what the springs that Poisson's effect lengthens, on
    # the tension law, leave), and anywhere in tension; at 45 degrees in compression it is
    # twice as stiff.
    for angle_deg, strain in ((0.0, -0.01), (90.0, -0.01), (0.0, 0.01), (45.0, 0.01)):
        assert _secant_pa(_ramp(angle_deg, strain), apart) == pytest.approx(
            _secant_pa(_ramp(angle_deg, strain), oblique), rel=0.04)
    assert _secant_pa(_ramp(45.0, -0.01), apart) > 1.8 * _secant_pa(_ramp(45.0, -0.01), oblique)


def test_a_reused_or_pickled_lattice_gives_the_forces_of_a_fresh_one() -> None:
    # A fit reuses one lattice for thousands of materials (it remembers their calibrations),
    # and the workers get it pickled after the parent used it.
    materials = (ANISOTROPIC, replace(ANISOTROPIC, oblique=-0.5),
                 replace(ANISOTROPIC, oblique_compression=0.5),
                 replace(ANISOTROPIC, sheet_over_normal=1.5))
    test = _ramp(30.0, 0.02)
    used = SpecimenLattice.of(CUBE)
    for material in materials:
        simulate_test(test, CUBE, material, used)
    travelled = pickle.loads(pickle.dumps(used))
    for material in reversed(materials):
        fresh = simulate_test(test, CUBE, material).force_n
        assert np.array_equal(simulate_test(test, CUBE, material, used).force_n, fresh)
        assert np.array_equal(simulate_test(test, CUBE, material, travelled).force_n, fresh)


def test_relaxation_under_a_hold_tends_to_g_infinity() -> None:
    material = replace(ISOTROPIC, relaxation_weights=(0.3, 0.2), relaxation_times_s=(0.5, 5.0))
    run = simulate_test(_ramp(0.0, 0.05, duration_s=0.01, hold_s=100.0), CUBE, material)
    elastic = simulate_test(_ramp(0.0, 0.05), CUBE, ISOTROPIC).force_n[-1]
    assert run.force_n[39] == pytest.approx(elastic, rel=0.01)  # a fast ramp: instantaneous
    assert run.force_n[-1] == pytest.approx(0.5 * elastic, rel=0.01)
    assert np.all(np.diff(run.force_n[40:]) < 0.0)


def test_non_linear_relaxation_relaxes_a_share_that_depends_on_the_strain() -> None:
    def relaxed(material: MassSpringMaterial, strain: float) -> float:
        run = simulate_test(_ramp(0.0, strain, duration_s=0.01, hold_s=100.0), CUBE, material)
        return 1.0 - run.force_n[-1] / run.force_n[39]

    linear = replace(ISOTROPIC, relaxation_weights=(0.3, 0.2), relaxation_times_s=(0.5, 5.0))
    shrinking = replace(linear, relaxation_strain_slope=-2.0)
    # Quasi-linear: half at any strain; with c = -2 about 0.5 (1 - 2 |x|) at spring strain x
    # (the springs along the load see the strain, the others less).
    assert relaxed(linear, 0.05) == pytest.approx(0.5, abs=0.01)
    assert relaxed(linear, 0.2) == pytest.approx(0.5, abs=0.01)
    assert 0.45 <= relaxed(shrinking, 0.05) <= 0.5
    assert 0.3 <= relaxed(shrinking, 0.2) <= 0.4
    growing = replace(linear, relaxation_strain_slope=2.0)
    assert relaxed(growing, 0.2) > 0.55
    # Half at the reference strain 0.2 (the springs along the load; the others, strained less,
    # relax less), with a slope that leaves none at small strains.
    from_none = replace(linear, relaxation_strain_slope=5.0, relaxation_reference_strain=0.2)
    assert 0.35 <= relaxed(from_none, 0.2) <= 0.5
    assert relaxed(from_none, 0.02) < 0.1


def test_plasticity_leaves_a_permanent_set() -> None:
    material = replace(ISOTROPIC, yield_strain=0.02, hardening=0.2)
    run = simulate_test(_cycle(0.0, 0.08, 8.0), CUBE, material)
    elastic = simulate_test(_cycle(0.0, 0.08, 8.0), CUBE, ISOTROPIC)
    assert run.force_n[40] < 0.6 * elastic.force_n[40]  # past yield, softer
    assert run.force_n[-1] < -0.1 * run.force_n[40]  # back at zero displacement: pushed
    assert elastic.force_n[-1] == pytest.approx(0.0, abs=1e-12)


def test_parallel_springs_alone_grouped_give_what_mirror_images_grouped_do() -> None:
    # The grouping fibres out of the x-z plane need (shear modes of turned fibres), on a path
    # where both hold: plastic, relaxing, oblique, every sample alike but for round-off.
    material = replace(ANISOTROPIC, yield_strain=0.02, hardening=0.2, relaxation_weights=(0.3,),
                       relaxation_times_s=(1.0,))
    lattice = SpecimenLattice.of(CUBE)
    parallel = replace(lattice, directions=lattice.parallel_directions,
                       weights=lattice.parallel_weights)
    assert len(parallel.directions) > len(lattice.directions)
    tests = [_cycle(35.0, 0.08, 8.0), _ramp(60.0, -0.1, hold_s=4.0)]
    for mirrored, alone in zip(simulate_tests(tests, CUBE, material, lattice),
                               simulate_tests(tests, CUBE, material, parallel), strict=True):
        np.testing.assert_allclose(alone.force_n, mirrored.force_n, rtol=1e-9, atol=1e-12)


def test_a_collapsed_specimen_is_a_divergence_not_data() -> None:
    with pytest.raises(DivergenceError, match="no equilibrium"):
        simulate_test(_ramp(0.0, -1.0), CUBE, ISOTROPIC)


def test_example_set_simulates() -> None:
    data = load_measurement_set(EXAMPLE)
    runs = simulate_set(data, ANISOTROPIC)
    assert [r.test_id for r in runs] == [t.test_id for t in data.tests]
    for run, test in zip(runs, data.tests, strict=True):
        assert run.force_n.shape == test.force_n.shape
        assert np.isfinite(run.force_n).all()


# Each meshed reference run takes 10-60 s.
@pytest.mark.slow
@pytest.mark.parametrize(("test", "material"), [
    pytest.param(_ramp(0.0, 0.04), ISOTROPIC, id="tension"),
    pytest.param(_ramp(45.0, 0.04), ANISOTROPIC, id="tension at 45 degrees"),
    pytest.param(_ramp(0.0, 0.03, duration_s=1.0, hold_s=1.5),
                 replace(ISOTROPIC, relaxation_weights=(0.4,), relaxation_times_s=(0.5,)),
                 id="relaxation"),
    pytest.param(_cycle(90.0, 0.04, 3.0), replace(ISOTROPIC, yield_strain=0.02, hardening=0.6),
                 id="plastic cycle"),
])
def test_quasi_static_lattice_is_within_two_percent_of_the_fine_slow_reference(
        test: MechanicalTest, material: MassSpringMaterial) -> None:
    fast = simulate_test(test, CUBE, material)
    reference = simulate_meshed(test, CUBE, material, REFERENCE)
    assert reference.inertia_ratio < 0.01
    error = np.abs(fast.force_n - reference.force_n).max() / np.abs(reference.force_n).max()
    assert error < 0.02
