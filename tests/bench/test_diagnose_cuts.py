"""The cut part of the diagnose bench (cell.bench.diagnose_cuts), on its pure pieces."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from cell.bench.diagnose_cuts import (
    FIRST_SEED,
    PAIRS,
    bench_seeds,
    hidden,
    parameter_error,
    reduced_vs_full,
)
from cell.diagnosis.cut.reduced import reduced_cut_forces
from cell.measure.cuts import Blade, Block, CutTest
from cell.tissue.cutmodel import CUT_CAUSES, CuttingParams


@dataclass(frozen=True)
class _Truth:
    cutting: CuttingParams
    offset_n: tuple[float, float, float]
    noise_n: float


@dataclass(frozen=True)
class _Set:
    block: Block
    blade: Blade
    cut_tests: tuple[CutTest, ...]
    folder: Path = Path("set")


def test_the_single_sets_cycle_through_the_catalogue_and_none() -> None:
    seeds = bench_seeds(len(CUT_CAUSES) + 1)
    assert [hidden(s, "single") for s in seeds] == [(c,) for c in CUT_CAUSES] + [()]
    assert {hidden(FIRST_SEED["pairs"] + k, "pairs") for k in range(len(PAIRS))} == set(PAIRS)
    assert min(seeds) >= 10_000


def test_parameter_errors_are_relative_norms() -> None:
    truth = _Truth(CuttingParams(900.0, layer_depths_m=(0.01,), layer_factors=(1.0, 2.0)),
                   (0.0, 0.0, 1.0), 0.1)
    fitted = CuttingParams(880.0, layer_depths_m=(0.011,), layer_factors=(1.0, 2.0))
    error = parameter_error("layered_toughness", truth, fitted, np.zeros(3))
    assert error == pytest.approx(0.001 / np.hypot(0.01, 2.0))
    assert parameter_error("blade_force_offset", truth, fitted,
                           np.array([0.0, 0.0, 1.1])) == pytest.approx(0.1)
    rubbing = _Truth(CuttingParams(900.0, face_friction=0.3, face_pressure_pa=1600.0),
                     (0.0, 0.0, 0.0), 0.1)
    assert parameter_error("blade_friction", rubbing, CuttingParams(
        900.0, face_friction=0.33, face_pressure_pa=1600.0), np.zeros(3)) == pytest.approx(0.1)
    wedged = _Truth(CuttingParams(900.0, face_modulus_pa=5e4), (0.0, 0.0, 0.0), 0.1)
    assert parameter_error("wedge_friction", wedged, CuttingParams(
        900.0, face_modulus_pa=5.5e4), np.zeros(3)) == pytest.approx(0.1)


def test_the_reduced_model_agrees_with_a_set_it_made() -> None:
    block = Block((0.06, 0.04, 0.03))
    blade = Blade(0.12, 0.0015, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
    t = np.linspace(0.0, 5.0, 200)
    edge = np.column_stack([0.03 + 0 * t, 0.02 + 0 * t, 0.032 - 0.006 * t])
    cutting = CuttingParams(900.0, slicing_efficiency=1.0)
    force = reduced_cut_forces(CutTest("c", t, edge, edge), block, blade, cutting).total_n + 0.5
    noisy = force + np.random.default_rng(0).normal(0.0, 0.1, force.shape)
    data = _Set(block, blade, (CutTest("c", t, edge, noisy),))
    assert reduced_vs_full(data, _Truth(cutting, (0.5, 0.5, 0.5), 0.1))[0] < 0.01
    assert reduced_vs_full(data, _Truth(cutting, (0.0, 0.0, 0.0), 0.1))[0] > 0.01
