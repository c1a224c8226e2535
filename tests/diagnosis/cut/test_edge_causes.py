"""The cutting model's terms with a state (cell.tissue.edgestate): the loading before the crack
runs, the friction along the edge, and a round block's section, in the reduced model, the full
simulation's edge term and the fit."""

from __future__ import annotations

import numpy as np
import pytest

from cell.cuttest.run import edge_term_n
from cell.cuttest.run import simulate_cut as simulate_full
from cell.diagnosis.cut.causes import CutCandidate, source_checks
from cell.diagnosis.cut.fitting import CutProblem, fit_cut
from cell.diagnosis.cut.reduced import reduced_cut_forces
from cell.errors import InputError
from cell.measure.cuts import Blade, Block, CutTest
from cell.tissue.cutmodel import CuttingParams
from cell.tissue.edgestate import edge_friction_state
from cell.tissue.material import default_meat

BLOCK = Block((0.06, 0.04, 0.03))
BLADE = Blade(0.12, 0.0015, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
UP = np.array([0.0, 0.0, 1.0])


def _path(t: np.ndarray, y: np.ndarray, z: np.ndarray) -> CutTest:
    edge = np.column_stack([np.full_like(t, 0.03), y, z])
    return CutTest("path", t, edge, np.zeros((len(t), 3)), None)


def _press_rest_back() -> CutTest:
    """Down 10 mm into the block at 5 mm/s, a second at rest, 1 mm back up."""
    t = np.linspace(0.0, 4.0, 801)
    z = BLOCK.top_z_m + 0.002 - 0.005 * np.minimum(t, 2.4) + 0.005 * np.clip(t - 3.4, 0, 0.2)
    return _path(t, np.full_like(t, 0.02), z)


def _saw(samples: int = 1200) -> CutTest:
    t = np.linspace(0.0, 6.0, samples)
    y = 0.02 + 0.01 * np.sin(2 * np.pi * t / 2.0)
    return _path(t, y, BLOCK.top_z_m + 0.001 - 0.002 * t)


def test_the_load_ramps_in_over_the_loading_depth_holds_at_rest_and_eases_off_backing_out(
        ) -> None:
    test = _press_rest_back()
    loaded = CuttingParams(1000.0, loading_depth_m=0.004)
    force = reduced_cut_forces(test, BLOCK, BLADE, loaded).edge_n[:, 2]
    depth = test.depth_m(BLOCK)
    full = 1000.0 * 0.04
    at = [int(np.argmin(np.abs(depth - d))) for d in (0.002, 0.008)]
    assert force[at[0]] == pytest.approx(0.5 * full, rel=0.02)
    assert force[at[1]] == pytest.approx(full, rel=1e-6)
    resting = (test.time_s > 2.5) & (test.time_s < 3.3)
    assert force[resting] == pytest.approx(full, rel=1e-6)  # the plain edge drops to 0
    assert force[-1] == pytest.approx(0.75 * full, rel=0.02)  # 1 mm of 4 mm backed out
    plain = reduced_cut_forces(test, BLOCK, BLADE, CuttingParams(1000.0)).edge_n[:, 2]
    assert plain[resting].max() == 0.0


def test_the_edge_friction_turns_with_the_stroke_through_zero_up_to_its_share_of_the_load(
        ) -> None:
    test = _saw()
    rubbing = CuttingParams(1000.0, loading_depth_m=0.002, edge_friction=0.5,
                            edge_slip_m=0.002)
    force = reduced_cut_forces(test, BLOCK, BLADE, rubbing).edge_n
    along, load = force[:, 1], force[:, 2]
    assert np.all(np.abs(along) <= 0.5 * load + 1e-9)
    moving = np.gradient(test.edge_m[:, 1], test.time_s)
    fast = np.abs(moving) > 0.8 * np.abs(moving).max()
    assert np.all(np.sign(along[fast & (load > 10.0)]) == -np.sign(moving[fast & (load > 10.0)]))
    # Through zero smoothly where the stroke turns: no jump between samples near the load.
    assert np.abs(np.diff(along)).max() < 0.1 * load.max()


def test_the_dahl_state_forgets_over_its_slip() -> None:
    state = edge_friction_state([0.0, 0.002, 0.002 - 1e-6], [1.0, 1.0, 1.0], 0.002)
    assert state[1] == pytest.approx(-(1 - np.exp(-1.0)))
    assert state[2] == pytest.approx(state[1] + (1 - state[1]) * (1 - np.exp(-5e-4)))


def test_the_full_simulations_edge_term_is_the_reduced_models_in_a_box() -> None:
    test = _saw()
    params = CuttingParams(800.0, slicing_efficiency=1.0, loading_depth_m=0.003,
                           edge_friction=0.6, edge_slip_m=0.002)
    reduced = reduced_cut_forces(test, BLOCK, BLADE, params).edge_n
    full = edge_term_n(test.time_s, test.edge_m, BLOCK, BLADE, params, UP)
    assert np.abs(full - reduced).max() <= 0.01 * np.abs(reduced).max()


def test_a_round_blocks_edge_length_is_the_chord_of_its_section() -> None:
    block = Block((0.04, 0.05, 0.05), section="round")
    t = np.linspace(0.0, 4.0, 401)
    test = _path(t, np.full_like(t, 0.025), 0.052 - 0.01 * t)
    forces = reduced_cut_forces(test, block, BLADE, CuttingParams(1000.0))
    depth = test.depth_m(block)
    cutting = (depth > 0.005) & (depth < 0.035)
    chord = 2 * np.sqrt(np.clip(depth * (0.05 - depth), 0.0, None))
    assert forces.engaged_length_m[cutting] == pytest.approx(chord[cutting], abs=0.0011)


def test_a_block_names_a_section_it_does_not_know_and_the_full_simulation_a_round_one() -> None:
    with pytest.raises(InputError, match="section"):
        Block((0.04, 0.05, 0.05), section="oval")
    t = np.linspace(0.0, 1.0, 11)
    with pytest.raises(InputError, match="box blocks only"):
        simulate_full(t, np.column_stack([0.02 + 0 * t, 0.025 + 0 * t, 0.06 - 0.01 * t]),
                      Block((0.04, 0.05, 0.05), section="round"), BLADE, default_meat(),
                      CuttingParams(500.0))


def test_a_fit_recovers_the_loading_and_the_edge_friction() -> None:
    truth = CuttingParams(900.0, loading_depth_m=0.003, edge_friction=0.7, edge_slip_m=0.0015)
    rng = np.random.default_rng(0)
    tests = []
    for k, stroke in enumerate((0.006, 0.01, 0.014)):
        saw = _saw(600)
        y = 0.02 + (saw.edge_m[:, 1] - 0.02) * stroke / 0.01
        path = _path(saw.time_s, y, saw.edge_m[:, 2])
        force = reduced_cut_forces(path, BLOCK, BLADE, truth).total_n
        tests.append(CutTest(f"s{k}", path.time_s, path.edge_m,
                             force + rng.normal(0.0, 0.05, force.shape)))
    problem = CutProblem.of(BLOCK, BLADE, tuple(tests), 64)
    model = CutCandidate(("edge_loading", "edge_friction"), 0.01, BLOCK.top_z_m)
    fit = fit_cut(problem, model, model.initial, 200)
    assert fit.params["toughness_j_m2"] == pytest.approx(900.0, rel=0.02)
    assert fit.params["loading_depth_m"] == pytest.approx(0.003, rel=0.05)
    assert fit.params["edge_friction"] == pytest.approx(0.7, rel=0.05)
    assert fit.params["edge_slip_m"] == pytest.approx(0.0015, rel=0.1)


def test_a_fitted_parameter_outside_its_sources_range_is_flagged_and_an_unsourced_one_said_so(
        ) -> None:
    checks = {c["parameter"]: c for c in source_checks(
        {"toughness_j_m2": 90.0, "slicing_efficiency": 1.46, "edge_friction": 0.9})}
    assert set(checks) == {"slicing_efficiency", "edge_friction"}
    assert checks["slicing_efficiency"]["outside"] is True
    assert checks["edge_friction"]["outside"] is None
    assert checks["edge_friction"]["range"] == [None, None]
