"""Small cut sets made by the reduced model for the tests of the cut diagnosis."""

from __future__ import annotations

import numpy as np

from cell.diagnosis.cut.reduced import reduced_cut_forces
from cell.measure.cuts import Blade, Block, CutTest
from cell.tissue.cutmodel import CuttingParams


def sawing_set(stiffness_n_m: float) -> tuple[Block, Blade, tuple[CutTest, ...]]:
    """Sawing cuts by the reduced model, plus a force along the edge that pulls the blade
    back to where the stroke began (stiffness_n_m times the stroke) while the edge is in
    the block: nothing the catalogue has."""
    block = Block((0.06, 0.2, 0.03))
    blade = Blade(0.2, 0.0015, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
    tests = []
    for k, (speed, period) in enumerate(((0.004, 2.0), (0.006, 1.6), (0.005, 2.4),
                                         (0.003, 1.8))):
        t = np.linspace(0.0, 5.0, 300)
        edge = np.column_stack([0.03 + 0 * t, 0.1 + 0.015 * np.sin(2 * np.pi * t / period),
                                0.032 - speed * t])
        force = reduced_cut_forces(CutTest("c", t, edge, edge), block, blade,
                             CuttingParams(800.0)).total_n
        inside = edge[:, 2] < block.size_m[2]
        force[:, 1] -= stiffness_n_m * (edge[:, 1] - edge[0, 1]) * inside
        noisy = force + np.random.default_rng(k).normal(0.0, 0.02, force.shape)
        tests.append(CutTest(f"c{k}", t, edge, noisy))
    return block, blade, tuple(tests)
