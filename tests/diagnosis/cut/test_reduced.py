"""The reduced model of a cut test (cell.diagnosis.cut.reduced)."""

from __future__ import annotations

import numpy as np
import pytest

from cell.diagnosis.cut.reduced import cutting_direction, edge_velocity_m_s, reduced_cut_forces
from cell.measure.cuts import Blade, Block, CutTest
from cell.tissue.cutmodel import CuttingParams

BLOCK = Block((0.06, 0.04, 0.03))
BLADE = Blade(0.12, 0.0015, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))


def _press(speed_m_s: float = 0.01, depth_m: float = 0.025, samples: int = 400,
           start_m: float = 0.032) -> CutTest:
    """A press cut from above the block down to ``depth_m`` and back up."""
    down = (start_m - BLOCK.top_z_m + depth_m) / speed_m_s
    t = np.linspace(0.0, 2 * down, samples)
    z = start_m - speed_m_s * np.minimum(t, 2 * down - t)
    edge = np.column_stack([np.full_like(t, 0.03), np.full_like(t, 0.02), z])
    return CutTest("press", t, edge, np.zeros((samples, 3)), None)


def _saw(stroke_m: float = 0.02, period_s: float = 1.0, sink_m_s: float = 0.005,
         samples: int = 800) -> CutTest:
    """A sawing cut: the edge moves back and forth along itself while it sinks."""
    t = np.linspace(0.0, 6.0, samples)
    y = 0.02 + 0.5 * stroke_m * np.sin(2 * np.pi * t / period_s)
    z = 0.032 - sink_m_s * t
    edge = np.column_stack([np.full_like(t, 0.03), y, z])
    return CutTest("saw", t, edge, np.zeros((samples, 3)), None)


def test_the_blade_cuts_downwards() -> None:
    assert cutting_direction(BLADE).tolist() == [0.0, 0.0, -1.0]


def test_a_press_cut_resists_with_the_toughness_times_the_block_width() -> None:
    forces = reduced_cut_forces(_press(), BLOCK, BLADE, CuttingParams(1000.0))
    cutting = forces.engaged_length_m > 0
    assert cutting.any()
    np.testing.assert_allclose(forces.engaged_length_m[cutting], 0.04)
    np.testing.assert_allclose(forces.edge_n[cutting, 2], 40.0, rtol=1e-9)
    np.testing.assert_allclose(forces.edge_n[:, :2], 0.0, atol=1e-12)


def test_nothing_is_cut_in_air_or_on_the_way_back() -> None:
    test = _press()
    forces = reduced_cut_forces(test, BLOCK, BLADE, CuttingParams(1000.0))
    in_air = test.edge_m[:, 2] > BLOCK.top_z_m
    rising = edge_velocity_m_s(test)[:, 2] > 0
    assert not forces.engaged_length_m[in_air | rising].any()


def test_face_friction_grows_with_depth_and_drags_the_blade_back_out() -> None:
    cutting = CuttingParams(1000.0, face_friction=0.4, face_pressure_pa=3000.0)
    test = _press()
    forces = reduced_cut_forces(test, BLOCK, BLADE, cutting)
    depth = BLOCK.top_z_m - test.edge_m[:, 2]
    velocity = edge_velocity_m_s(test)[:, 2]
    sinking = (depth > 0.002) & (velocity < -1e-6)
    rising = (depth > 0.002) & (velocity > 1e-6)
    expected = 2 * 0.4 * 3000.0 * 0.04 * depth
    np.testing.assert_allclose(forces.faces_n[sinking, 2], expected[sinking], rtol=1e-6)
    np.testing.assert_allclose(forces.faces_n[rising, 2], -expected[rising], rtol=1e-6)


def test_the_same_depth_cut_again_is_not_cut_again() -> None:
    t = np.linspace(0.0, 4.0, 401)
    z = 0.032 - 0.01 * np.minimum(t, 2.0) + 0.01 * np.clip(t - 2.0, 0.0, 1.0) \
        - 0.01 * np.clip(t - 3.0, 0.0, 1.0)
    edge = np.column_stack([np.full_like(t, 0.03), np.full_like(t, 0.02), z])
    forces = reduced_cut_forces(CutTest("again", t, edge, np.zeros((401, 3))), BLOCK, BLADE,
                          CuttingParams(1000.0))
    above_the_front = (t > 2.05) & (z > z.min() + 1e-4)
    assert not forces.engaged_length_m[above_the_front].any()


def test_a_noisy_logged_path_cuts_where_the_edge_sinks() -> None:
    test = _press()
    noisy = test.edge_m + np.random.default_rng(1).normal(0.0, 1e-6, test.edge_m.shape)
    forces = reduced_cut_forces(CutTest("noisy", test.time_s, noisy, test.force_n), BLOCK, BLADE,
                          CuttingParams(1000.0))
    exact = reduced_cut_forces(test, BLOCK, BLADE, CuttingParams(1000.0))
    np.testing.assert_array_equal(forces.engaged_length_m > 0, exact.engaged_length_m > 0)


def test_slicing_lowers_the_force_of_a_sawing_cut() -> None:
    test = _saw()
    plain = reduced_cut_forces(test, BLOCK, BLADE, CuttingParams(1000.0))
    sliced = reduced_cut_forces(test, BLOCK, BLADE, CuttingParams(1000.0, slicing_efficiency=1.0))
    cutting = plain.engaged_length_m > 0
    assert (sliced.edge_n[cutting, 2] < plain.edge_n[cutting, 2]).mean() > 0.9
    assert sliced.edge_n[cutting, 2].mean() < 0.5 * plain.edge_n[cutting, 2].mean()


def test_a_faster_cut_is_stronger_with_a_rate_exponent() -> None:
    cutting = CuttingParams(1000.0, reference_speed_m_s=0.01, rate_exponent=0.3)
    slow = reduced_cut_forces(_press(0.01), BLOCK, BLADE, cutting)
    fast = reduced_cut_forces(_press(0.04), BLOCK, BLADE, cutting)
    assert fast.edge_n[:, 2].max() == pytest.approx(40.0 * 4**0.3, rel=1e-6)
    assert slow.edge_n[:, 2].max() == pytest.approx(40.0, rel=1e-6)


def test_layers_step_the_force_at_their_depths() -> None:
    cutting = CuttingParams(1000.0, layer_depths_m=(0.01,), layer_factors=(1.0, 2.0))
    test = _press()
    forces = reduced_cut_forces(test, BLOCK, BLADE, cutting)
    depth = BLOCK.top_z_m - test.edge_m[:, 2]
    cutting_now = forces.engaged_length_m > 0
    np.testing.assert_allclose(forces.edge_n[cutting_now & (depth < 0.0099), 2], 40.0)
    np.testing.assert_allclose(forces.edge_n[cutting_now & (depth > 0.0101), 2], 80.0)


def test_the_indentation_ramp_starts_the_force_from_zero() -> None:
    test = _press()
    forces = reduced_cut_forces(test, BLOCK, BLADE,
                                CuttingParams(1000.0, indentation_depth_m=0.004))
    depth = BLOCK.top_z_m - test.edge_m[:, 2]
    ramp = (forces.engaged_length_m > 0) & (depth < 0.004)
    np.testing.assert_allclose(forces.edge_n[ramp, 2], 40.0 * depth[ramp] / 0.004, rtol=0.05)


def test_irregular_and_dropped_samples_give_the_same_force() -> None:
    test = _press(samples=800)
    keep = np.sort(np.random.default_rng(0).choice(800, 500, replace=False))
    thinned = CutTest("thin", test.time_s[keep], test.edge_m[keep], test.force_n[keep])
    cutting = CuttingParams(1000.0, face_friction=0.3, face_pressure_pa=2000.0)
    full = reduced_cut_forces(test, BLOCK, BLADE, cutting)
    part = reduced_cut_forces(thinned, BLOCK, BLADE, cutting)
    inside = (thinned.edge_m[:, 2] < BLOCK.top_z_m - 0.001)
    np.testing.assert_allclose(part.total_n[inside], full.total_n[keep][inside], atol=0.5)


