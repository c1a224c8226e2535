"""The wedge's face friction (cutting model ``face_modulus_pa``, cause ``wedge_friction``): the
blade's thickness and bevel open the cut, the faces press with the modulus times the opening
strain, the drag grows with the depth of blade in the material; the reduced model against the
full simulation."""

from __future__ import annotations

import numpy as np
import pytest

from cell.cuttest.run import CutSimulation
from cell.cuttest.run import simulate_cut as simulate_full
from cell.diagnosis.cut.causes import source_checks
from cell.diagnosis.cut.reduced import reduced_cut_forces
from cell.errors import InputError
from cell.measure.cuts import Blade, Block, CutTest
from cell.measure.wedge import wedge_height_m
from cell.tissue.cutmodel import CuttingParams
from cell.tissue.material import default_meat

BLOCK = Block((0.06, 0.04, 0.03))
BLADE = Blade(0.12, 0.0015, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), 20.0)
WEDGE = CuttingParams(800.0, face_modulus_pa=6e4)


def _press(depth_m: float = 0.02, speed_m_s: float = 0.005) -> CutTest:
    t = np.linspace(0.0, (depth_m + 0.002) / speed_m_s, 600)
    edge = np.column_stack([np.full_like(t, 0.03), np.full_like(t, 0.02),
                            BLOCK.top_z_m + 0.002 - speed_m_s * t])
    return CutTest("press", t, edge, np.zeros((len(t), 3)), None)


def _saw() -> CutTest:
    t = np.linspace(0.0, 8.0, 1600)
    edge = np.column_stack([np.full_like(t, 0.03), 0.02 + 0.01 * np.sin(np.pi * t),
                            BLOCK.top_z_m + 0.001 - 0.0025 * t])
    return CutTest("saw", t, edge, np.zeros((len(t), 3)), None)


def test_the_bevel_opens_the_cut_from_the_edges_radius_to_the_full_thickness() -> None:
    blade = Blade(0.1, 0.002, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), 90.0, 0.0)
    # A 90 degree bevel on a 2 mm blade is 1 mm long: half open on average along it.
    assert wedge_height_m(blade, np.array([0.001, 0.011])).tolist() == pytest.approx(
        [0.0005, 0.0105])
    rounded = Blade(0.1, 0.002, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), 90.0, 1e-4)
    assert wedge_height_m(rounded, np.array([1e-5]))[0] > wedge_height_m(
        blade, np.array([1e-5]))[0]
    assert Blade(0.1, 0.002, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0)).bevel_deg == 20.0
    with pytest.raises(InputError, match="edge_radius_m"):
        Blade(0.1, 0.002, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), 20.0, 0.001)


def test_the_wedges_drag_grows_with_depth_from_the_modulus_and_the_opening_strain() -> None:
    forces = reduced_cut_forces(_press(), BLOCK, BLADE, WEDGE)
    depth = forces.depth_m
    drag = forces.faces_n[:, 2]  # up, against the blade sinking
    # Past the bevel (4.3 mm long) the drag is mu E (t / W) over twice the opened area.
    deep = depth > 0.01
    strain = 0.0015 / 0.06
    bevel = 0.00075 / np.tan(np.radians(10.0))
    opened = BLOCK.size_m[1] * (depth[deep] - bevel / 2)
    assert drag[deep] == pytest.approx(2 * 6e4 * strain * opened, rel=0.02)
    assert np.all(np.diff(drag[depth > 0]) >= -1e-9)
    # Along the bevel it grows faster than the area: quadratically from first contact.
    shallow = (depth > 0.0005) & (depth < 0.002)
    ratio = drag[shallow] / (2 * 6e4 * strain * BLOCK.size_m[1] * depth[shallow])
    assert np.all(ratio < 0.5) and np.all(np.diff(ratio) > 0)


@pytest.mark.slow
def test_the_reduced_models_wedge_is_the_full_simulations_within_a_tenth_of_the_peak() -> None:
    test = _saw()
    params = CuttingParams(800.0, slicing_efficiency=1.0, face_modulus_pa=6e4)
    full = simulate_full(test.time_s, test.edge_m, BLOCK, BLADE, default_meat(), params,
                         CutSimulation(cell_size_m=0.005))
    reduced = reduced_cut_forces(test, BLOCK, BLADE, params)
    peak = np.abs(full.force_n).max()
    rmse = np.sqrt(np.mean((full.force_n - reduced.total_n) ** 2))
    assert rmse <= 0.1 * peak
    # The wedge's drag itself, the full simulation's contacts taken out.
    plain = simulate_full(test.time_s, test.edge_m, BLOCK, BLADE, default_meat(),
                          CuttingParams(800.0, slicing_efficiency=1.0),
                          CutSimulation(cell_size_m=0.005))
    wedge_full = full.faces_n - plain.faces_n
    wedge_reduced = reduced.faces_n
    assert np.abs(wedge_full - wedge_reduced).max() <= 0.1 * np.abs(wedge_reduced).max()


def test_a_fitted_mu_e_outside_its_sources_range_is_flagged() -> None:
    (low,) = source_checks({"face_modulus_pa": 500.0})
    (within,) = source_checks({"face_modulus_pa": 6e4})
    assert low["outside"] is True and within["outside"] is False
