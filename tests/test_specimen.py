"""Simulated tests: the specimen's force against closed forms, fibre order, and the fast
(mass-scaled) run against a fine, slow reference."""

import time
from pathlib import Path

import numpy as np
import pytest

from cell.material import ContinuumMaterial, MassSpringMaterial
from cell.measured import MechanicalTest, Specimen, load_measurement_set
from cell.specimen import (
    SimulatedTest,
    SpecimenSimParams,
    fibre_direction,
    simulate_set,
    simulate_test,
    specimen_mesh,
)

EXAMPLE = Path(__file__).resolve().parents[1] / "assets" / "measured" / "beef_round_example"
CUBE = Specimen("cube", (0.01, 0.01, 0.01))
# Anisotropic springs in the range of muscle in compression, Pa.
ANISOTROPIC = MassSpringMaterial.transversely_isotropic(12e3, 6e3)
# The real specimen at half the stable step.
REFERENCE = SpecimenSimParams(max_mass_scale=1.0, timestep_safety=0.45)



def _ramp(angle_deg: float, strain: float, rate_per_s: float, samples: int = 100,
          mode: str = "tension") -> MechanicalTest:
    """A ramp from rest to ``strain`` at ``rate_per_s`` on :data:`CUBE`."""
    t = np.linspace(0.0, abs(strain) / rate_per_s, samples)
    return MechanicalTest("ramp", mode, angle_deg, t, strain * CUBE.size_m[2] * t / t[-1],
                          np.zeros(samples))


def _cycles(angle_deg: float, amplitude: float, rate_per_s: float, cycles: int) -> MechanicalTest:
    """Tension-compression triangle cycles about zero on :data:`CUBE`."""
    period = 4.0 * amplitude / rate_per_s
    t = np.linspace(0.0, cycles * period, 120 * cycles)
    phase = (t / period + 0.25) % 1.0
    strain = amplitude * (1.0 - 4.0 * np.abs(phase - 0.5))
    return MechanicalTest("cycles", "cyclic", angle_deg, t, strain * CUBE.size_m[2],
                          np.zeros_like(t))


def _axial_modulus(run: SimulatedTest, test: MechanicalTest) -> float:
    """Force over area and strain at the last sample, Pa."""
    return float(run.force_N[-1] / CUBE.area_m2 / test.strain(CUBE)[-1])


def test_mesh_spans_the_specimen_and_fibres_turn_in_the_xz_plane() -> None:
    mesh = specimen_mesh(Specimen("slab", (0.02, 0.01, 0.005)), 4)
    np.testing.assert_allclose(mesh.points.max(axis=0), (0.02, 0.01, 0.005))
    assert len(mesh.tets) == 6 * 4 * 2 * 1
    np.testing.assert_allclose(fibre_direction(0.0), (0.0, 0.0, 1.0))
    np.testing.assert_allclose(fibre_direction(45.0), (0.5**0.5, 0.0, 0.5**0.5))


@pytest.mark.parametrize(("material", "tolerance"), [
    # Zero Poisson's ratio: bonded platens hold nothing back, F = E A strain.
    (ContinuumMaterial(young_pa=6e3, poisson=0.0), 0.03),
    # The spring lattice's Poisson's ratio (0.16) stiffens a bonded cube a little.
    (MassSpringMaterial.isotropic(6e3), 0.05),
])
def test_linear_isotropic_tension_is_young_area_strain(
    material: ContinuumMaterial | MassSpringMaterial, tolerance: float
) -> None:
    test = _ramp(0.0, 0.01, 0.01)
    run = simulate_test(test, CUBE, material)
    assert _axial_modulus(run, test) == pytest.approx(6e3, rel=tolerance)
    assert run.inertia_ratio < 0.02


@pytest.mark.parametrize(("strain", "mode"), [(0.02, "tension"), (-0.02, "compression")])
def test_fibres_along_the_load_are_stiffer_than_across(strain: float, mode: str) -> None:
    test = {angle: _ramp(angle, strain, 0.01, mode=mode) for angle in (0.0, 90.0)}
    along, across = (
        _axial_modulus(simulate_test(test[a], CUBE, ANISOTROPIC), test[a]) for a in (0.0, 90.0)
    )
    assert along > 1.6 * across
    assert along == pytest.approx(12e3, rel=0.1)
    assert across == pytest.approx(6e3, rel=0.1)


@pytest.mark.parametrize("test", [
    _ramp(0.0, 0.08, 0.01),
    _cycles(90.0, 0.06, 0.02, 1),
], ids=["slow tension ramp", "tension-compression cycle"])
def test_fast_run_is_within_two_percent_of_the_slow_reference(test: MechanicalTest) -> None:
    fast = simulate_test(test, CUBE, ANISOTROPIC)
    reference = simulate_test(test, CUBE, ANISOTROPIC, REFERENCE)
    assert fast.mass_scale > 10.0
    assert reference.mass_scale == 1.0
    assert reference.steps > 10 * fast.steps
    error = np.abs(fast.force_N - reference.force_N).max() / np.abs(reference.force_N).max()
    assert error < 0.02


def test_continuum_reports_the_compressed_volume() -> None:
    test = _ramp(0.0, -0.3, 0.05, mode="compression")
    run = simulate_test(test, CUBE, ContinuumMaterial(young_pa=6e3, poisson=0.3))
    assert 0.5 < run.min_volume_ratio < 0.9
    assert run.force_N[-1] < 0.0


def test_example_set_simulates_in_parallel() -> None:
    data = load_measurement_set(EXAMPLE)
    start = time.perf_counter()
    runs = simulate_set(data, MassSpringMaterial.isotropic(6e3), workers=2)
    elapsed = time.perf_counter() - start
    assert [r.test_id for r in runs] == [t.test_id for t in data.tests]
    for run, test in zip(runs, data.tests, strict=True):
        assert run.force_N.shape == test.force_N.shape
        assert np.isfinite(run.force_N).all()
    print(f"example set: {len(runs)} tests, {sum(r.steps for r in runs)} steps, {elapsed:.1f} s")


def test_params_are_checked() -> None:
    with pytest.raises(ValueError, match="max_mass_scale"):
        SpecimenSimParams(max_mass_scale=0.5)
    with pytest.raises(ValueError, match="timestep_safety"):
        SpecimenSimParams(timestep_safety=1.5)
