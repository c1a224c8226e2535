"""Small cut sets made by the reduced model for the tests of the cut diagnosis: presses and
sawing strokes through a block, a set of them with noise and offsets, and a set of both kinds."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cell.diagnosis.cut.reduced import reduced_cut_forces
from cell.measure.cuts import Blade, Block, CutTest
from cell.synthetic.specimen import write_hidden_effect_set
from cell.tissue.cutmodel import CuttingParams

BLOCK = Block((0.06, 0.04, 0.03))
BLADE = Blade(0.12, 0.0015, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
PLAIN = CuttingParams(900.0, face_pressure_pa=1600.0)


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


def press(speed_m_s: float, depth_m: float = 0.025, samples: int = 240
           ) -> tuple[np.ndarray, np.ndarray]:
    """From 2 mm above the block down to ``depth_m`` and back."""
    down = (0.002 + depth_m) / speed_m_s
    t = np.linspace(0.0, 2.0 * down, samples)
    z = 0.032 - speed_m_s * np.minimum(t, 2.0 * down - t)
    return t, np.column_stack([np.full_like(t, 0.03), np.full_like(t, 0.02), z])


def saw(sink_m_s: float, stroke_m: float = 0.02, samples: int = 320
         ) -> tuple[np.ndarray, np.ndarray]:
    """Back and forth along the edge once a second while sinking to 25 mm."""
    t = np.linspace(0.0, 0.027 / sink_m_s, samples)
    y = 0.02 + 0.5 * stroke_m * np.sin(2.0 * np.pi * t)
    return t, np.column_stack([np.full_like(t, 0.03), y, 0.032 - sink_m_s * t])


def cut_set(truth: CuttingParams, offset_n: tuple[float, float, float] = (0.0, 0.0, 0.0),
             paths: list | None = None, seed: int = 0) -> tuple[CutTest, ...]:
    """Cut tests of ``truth`` with 0.2 N of noise on each channel."""
    rng = np.random.default_rng(seed)
    paths = paths or [press(0.005), press(0.01), press(0.03), press(0.01, 0.015),
                      saw(0.004), saw(0.008)]
    tests = []
    for k, (t, edge) in enumerate(paths):
        force = reduced_cut_forces(CutTest("truth", t, edge, edge), BLOCK, BLADE,
                                   truth).total_n
        force = force + np.asarray(offset_n) + rng.normal(0.0, 0.2, force.shape)
        tests.append(CutTest(f"cut{k}", t, edge, force))
    return tuple(tests)


def mixed_set(folder: Path, cut_tests: tuple[CutTest, ...],
              effect: str | tuple[str, ...] | None = None) -> None:
    """A generated uniaxial set with ``effect`` hidden (none by default) and ``cut_tests``
    beside it, every row leaving the other kind's columns empty."""
    write_hidden_effect_set(folder, 2, effect)
    specimen = folder / "specimen.toml"
    specimen.write_text(specimen.read_text() + "\n[block]\nsize_m = [0.06, 0.04, 0.03]\n\n"
                        "[blade]\nedge_length_m = 0.12\nthickness_m = 0.0015\n"
                        "edge_direction = [0.0, 1.0, 0.0]\nblade_normal = [1.0, 0.0, 0.0]\n")
    lines = (folder / "tests.csv").read_text().splitlines()
    cut_columns = "edge_x_m,edge_y_m,edge_z_m,force_x_N,force_y_N,force_z_N"
    rows = [f"{lines[0]},{cut_columns}", *(f"{line},,,,,," for line in lines[1:])]
    for test in cut_tests:
        for t, edge, force in zip(test.time_s, test.edge_m, test.force_n, strict=True):
            cells = [test.test_id, "cut", "", repr(float(t)), "", "",
                     *(repr(float(v)) for v in (*edge, *force))]
            rows.append(",".join(cells))
    (folder / "tests.csv").write_text("\n".join(rows) + "\n")
