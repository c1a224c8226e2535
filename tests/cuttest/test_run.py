"""The full simulation of a cut test (cell.cuttest.run) and the hidden-effect cut sets made with
it (cell.synthetic.cut)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cell.cuttest.run import CutSimulation, engaged_length_m, knife_sensor_to_spec, simulate_cut
from cell.errors import DivergenceError, InputError
from cell.measure.cuts import Blade, Block
from cell.measure.specimens import load_measurement_set
from cell.synthetic.cut import describe, write_hidden_cut_set
from cell.tissue.cutmodel import CuttingParams
from cell.tissue.material import default_meat
from tests.marks import slow_but

BLADE = Blade(0.12, 0.0015, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), 20.0)
CUTTING = CuttingParams(toughness_j_m2=600.0, face_friction=0.5, indentation_depth_m=0.002)
COARSE = CutSimulation(cell_size_m=0.01)


def press(block: Block, depth_m: float, speed_m_s: float = 0.01, rate_hz: float = 100.0,
          back_m: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A press cut from 2 mm above the block's top centre to ``depth_m``, then back."""
    sink = (depth_m + 0.002) / speed_m_s
    time = np.arange(0.0, sink + back_m / speed_m_s, 1.0 / rate_hz)
    height = np.where(time <= sink, -speed_m_s * time, -speed_m_s * (2 * sink - time))
    x, y, z = np.asarray(block.size_m) / 2
    return time, np.stack([np.full_like(time, x), np.full_like(time, y),
                           2 * z + 0.002 + height], axis=1)


def test_force_rises_as_the_edge_enters_and_scales_with_the_engaged_length() -> None:
    forces = {}
    for width in (0.02, 0.04):
        block = Block((0.04, width, 0.02))
        time, edge = press(block, 0.01)
        run = simulate_cut(time, edge, block, BLADE, default_meat(), CUTTING, COARSE)
        depth = block.top_z_m - edge[:, 2]
        assert np.abs(run.force_n[depth < -0.0005]).max() < 1e-6  # in air: nothing
        ramp = run.force_n[(depth > 0.0) & (depth < 0.002), 2]
        assert np.all(np.diff(ramp) > -0.05 * ramp.max())  # rises through the indentation
        forces[width] = run.force_n[depth > 0.004, 2].mean()
        assert forces[width] == pytest.approx(CUTTING.toughness_j_m2 * width, rel=0.1)
    assert forces[0.04] / forces[0.02] == pytest.approx(2.0, rel=0.1)


def test_the_block_separates_behind_the_edge() -> None:
    block = Block((0.04, 0.03, 0.03))
    time, edge = press(block, 0.015)
    run = simulate_cut(time, edge, block, BLADE, default_meat(), CUTTING, COARSE)
    assert run.released[0] < run.released[len(time) // 2] < run.released[-1] < run.ties
    assert np.all(np.diff(run.released) >= 0)  # released for good


def test_sign_convention_the_block_pushes_back_on_the_blade() -> None:
    block = Block((0.04, 0.03, 0.02))
    time, edge = press(block, 0.01, back_m=0.004)
    run = simulate_cut(time, edge, block, BLADE, default_meat(), CUTTING, COARSE)
    sinking = np.gradient(edge[:, 2], time) < 0
    inside = block.top_z_m - edge[:, 2] > 0.003
    assert np.all(run.force_n[sinking & inside, 2] > 0.0)  # against the sinking blade
    assert np.allclose(run.force_n, run.edge_n + run.faces_n)
    sensor = knife_sensor_to_spec(run.force_n)  # what the cell's knife sensor would read
    assert np.all(sensor[sinking & inside, 2] < 0.0)
    assert np.array_equal(knife_sensor_to_spec(sensor), run.force_n)
    # Drawn back (both sides of a sample), the edge cuts nothing: only the faces drag.
    up = np.diff(edge[:, 2]) > 0.0
    rising = np.zeros(len(time), dtype=bool)
    rising[1:-1] = up[:-1] & up[1:]
    assert (rising & inside).sum() > 10
    assert np.all(run.edge_n[rising] == 0.0)


def test_sawing_lowers_the_force_to_sink_and_drags_along_the_edge() -> None:
    block = Block((0.04, 0.03, 0.02))
    slicing = replace(CUTTING, slicing_efficiency=1.0)
    time, edge = press(block, 0.01)
    edge[:, 1] += 0.01 * np.sin(2 * np.pi * time)
    run = simulate_cut(time, edge, block, BLADE, default_meat(), slicing, COARSE)
    pressed = simulate_cut(*press(block, 0.01), block, BLADE, default_meat(), slicing, COARSE)
    deep = block.top_z_m - edge[:, 2] > 0.004
    assert run.edge_n[deep, 2].mean() < 0.5 * pressed.edge_n[deep, 2].mean()
    along = np.gradient(edge[:, 1], time)
    moving = deep & (np.abs(along) > 0.02)
    assert np.all(np.sign(run.edge_n[moving, 1]) == -np.sign(along[moving]))


def test_engaged_length_is_the_edge_inside_the_block() -> None:
    block = Block((0.06, 0.04, 0.03))
    along_y = np.array([0.0, 1.0, 0.0])
    assert engaged_length_m(block, np.array([0.03, 0.0, 0.01]), along_y, 0.02) == 0.01
    assert engaged_length_m(block, np.array([0.03, 0.02, 0.031]), along_y, 0.12) == 0.0


def test_a_blowup_raises_divergence_and_bad_paths_are_refused() -> None:
    block = Block((0.04, 0.03, 0.02))
    time, edge = press(block, 0.01)
    with pytest.raises(DivergenceError):
        simulate_cut(time, edge, block, BLADE, default_meat(), CUTTING,
                     CutSimulation(0.01, max_tissue_speed_m_s=1e-9))
    with pytest.raises(InputError):
        simulate_cut(time[::-1], edge, block, BLADE, default_meat(), CUTTING, COARSE)
    oblique = Blade(0.12, 0.0015, (0.0, 1.0, 0.0), (0.6, 0.0, 0.8))
    with pytest.raises(InputError, match="plane of the block's axes"):
        simulate_cut(time, edge, block, oblique, default_meat(), CUTTING, COARSE)


def test_the_force_does_not_depend_on_the_mesh() -> None:
    """The same cutting parameters give the same force at 5 mm and 10 mm cells (within 10 %
    of the peak, sample by sample, while the edge is in the block)."""
    block = Block((0.04, 0.03, 0.02))
    time, edge = press(block, 0.012, back_m=0.003)
    runs = [simulate_cut(time, edge, block, BLADE, default_meat(), CUTTING, CutSimulation(h))
            for h in (0.005, 0.01)]
    inside = block.top_z_m - edge[:, 2] > 0.0
    fine, coarse = (run.force_n[inside] for run in runs)
    peak = np.abs(fine).max()
    assert np.abs(fine - coarse).max() < 0.1 * peak
    assert np.sqrt(np.mean(np.sum((fine - coarse) ** 2, axis=1))) < 0.05 * peak


def test_a_generated_set_reads_back_and_holds_no_truth(tmp_path: Path) -> None:
    folder = tmp_path / "set"
    truth = write_hidden_cut_set(folder, seed=5, causes=("layered_toughness",
                                                         "blade_force_offset"),
                                 tests=2, cell_size_m=0.012)
    assert sorted(p.name for p in folder.iterdir()) == ["specimen.toml", "tests.csv"]
    data = load_measurement_set(folder)
    assert len(data.cut_tests) == 2 and data.block is not None and data.blade is not None
    for test in data.cut_tests:
        assert np.all(np.diff(test.time_s) > 0)
        gaps = np.diff(test.time_s)
        assert gaps.max() > 1.5 * np.median(gaps)  # dropped samples, irregular sampling
    header, *rows = (folder / "tests.csv").read_text().splitlines()
    assert header.split(",") == ["test_id", "mode", "time_s", "edge_x_m", "edge_y_m",
                                 "edge_z_m", "force_x_N", "force_y_N", "force_z_N"]
    assert all(row.split(",")[1] == "cut" for row in rows)
    text = (folder / "specimen.toml").read_text().lower()
    for cause in ("layered", "offset", "toughness", "friction", "slicing", "indentation"):
        assert cause not in text
    described = describe(truth)
    for value in (described["toughness_j_m2"], *described["layer_depths_m"],
                  *described["layer_factors"][1:], *described["offset_n"]):
        assert f"{value:.3g}" not in text
    # The sensor's offset shows in air, before the edge reaches the block.
    first = data.cut_tests[0]
    in_air = first.edge_m[:, 2] > data.block.top_z_m + 0.0005
    assert np.allclose(first.force_n[in_air].mean(axis=0), truth.offset_n,
                       atol=3 * truth.noise_n / np.sqrt(in_air.sum()) + 0.05)


@pytest.mark.parametrize("causes", slow_but({("slicing",)}, [("slicing",), ()],
                                             ids=lambda causes: "+".join(causes) or "none"))
def test_a_generated_sawing_and_press_cut_tell_whether_slicing_acts(
        tmp_path: Path, causes: tuple[str, ...]) -> None:
    # One press and one sawing cut of the same generated material (the full simulation, on
    # coarse cells to stay quick), diagnosed together (issue 33, acceptance 2): slicing is
    # named when it is hidden, and only then.
    from cell.diagnosis.cut.search import diagnose_cuts
    from cell.diagnosis.engine.settings import DiagnosisParams

    write_hidden_cut_set(tmp_path / "set", seed=11, causes=causes, tests=2, cell_size_m=0.012)
    data = load_measurement_set(tmp_path / "set")
    assert [float(np.ptp(t.edge_m[:, 1])) > 0.005 for t in data.cut_tests] == [False, True]
    named = diagnose_cuts(data.block, data.blade, data.cut_tests,
                          DiagnosisParams(workers=1)).causes
    assert ("slicing" in named) == bool(causes), named
