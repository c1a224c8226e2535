"""The knife's cutting force in the cell: the material's cutting model in the seam
(``aponeurosis.knife_force = "cutting"``) or the measured curve (``"curve"``)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cell.errors import ScenarioError
from cell.perception.params import PerceptionParams
from cell.sim.episode import Episode
from cell.sim.scenario import AponeurosisParams, Scenario, load_scenario
from cell.tissue.cutmodel import CuttingParams, beef_cutting
from cell.tissue.geometry import build_two_muscles
from cell.tissue.seamcut import STALL_SPEED_M_S, SeamCut
from cell.tissue.shape import MuscleShape
from controllers.gripper import PullPlan
from controllers.knife import CutPlan
from tests.paths import DEFAULT_SCENARIO

#: The cell's blade (x width, y thickness, z length, half sizes, m), upright, edge along +x.
HALF = np.array([0.0125, 0.0005, 0.1])
UPRIGHT = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
SPEED_M_S = 0.03
FORWARD = np.array([SPEED_M_S, 0.0, 0.0])
CLEARANCE_M = 0.0025


def _cut_along(seam: SeamCut, x_m: np.ndarray, tip_z_m: float,
               velocity: np.ndarray = FORWARD) -> np.ndarray:
    """The load on the blade (edge and faces, N, (n, 3)) with its tip at ``tip_z_m`` and its
    edge at each of ``x_m`` in turn."""
    centre_z = tip_z_m + HALF[2]
    return np.array([seam.load(np.array([x - HALF[0], 0.0, centre_z]), UPRIGHT, HALF,
                               velocity).on_blade_n for x in x_m])


def _seam(cell_size_m: float, params: CuttingParams) -> SeamCut:
    mesh = build_two_muscles(MuscleShape(cell_size_m=cell_size_m))
    return SeamCut(params, mesh.top_line, float(mesh.origin_m[2]))


def test_the_edge_meets_the_seam_from_its_top_down_to_the_tip() -> None:
    top = np.array([[-0.2, 0.0, 0.07], [0.2, 0.0, 0.07]])
    seam = SeamCut(CuttingParams(toughness_j_m2=170.0), top, 0.0)
    load = seam.load(np.array([0.0, 0.0, 0.12]), UPRIGHT, HALF, FORWARD)
    assert load.engaged_m == pytest.approx(0.05)  # from 0.07 m down to the tip at 0.02 m
    assert load.edge_n[0] == pytest.approx(-170.0 * 0.05 * np.tanh(SPEED_M_S / STALL_SPEED_M_S))
    assert load.resistance_n == pytest.approx(170.0 * 0.05)
    outside = seam.load(np.array([0.3, 0.0, 0.12]), UPRIGHT, HALF, FORWARD)
    assert outside.engaged_m == 0.0 and not outside.on_blade_n.any()


def test_a_second_deeper_pass_cuts_only_what_the_first_left() -> None:
    top = np.array([[-0.2, 0.0, 0.07], [0.2, 0.0, 0.07]])
    seam = SeamCut(CuttingParams(toughness_j_m2=100.0), top, 0.0)
    path = np.arange(-0.19, 0.19, 0.001)
    first = _cut_along(seam, path, 0.04)
    assert np.median(-first[:, 0]) == pytest.approx(100.0 * 0.03, rel=1e-3)
    seam.load(np.array([-0.3, 0.0, 0.5]), UPRIGHT, HALF, np.zeros(3))  # out and back
    second = _cut_along(seam, path, 0.01)
    assert np.median(-second[:, 0]) == pytest.approx(100.0 * 0.03, rel=1e-3)
    back = _cut_along(seam, path[::-1], 0.01, np.array([-SPEED_M_S, 0.0, 0.0]))
    assert not back.any()  # no friction without a [cutting] table's faces, no edge: all cut


def test_the_faces_drag_with_the_blades_area_in_the_meat() -> None:
    params = CuttingParams(toughness_j_m2=170.0, face_friction=0.3, face_pressure_pa=1600.0)
    top = np.array([[-0.2, 0.0, 0.07], [0.2, 0.0, 0.07]])
    seam = SeamCut(params, top, 0.0)
    seam.load(np.array([0.0, 0.0, 0.12]), UPRIGHT, HALF, FORWARD)
    # Drawn back up its own cut: no edge force, the faces drag 2 mu p A against the motion.
    load = seam.load(np.array([0.0, 0.0, 0.12]), UPRIGHT, HALF, np.array([0.0, 0.0, 0.03]))
    area = 0.05 * 2 * HALF[0]
    assert load.face_area_m2 == pytest.approx(area)
    assert not load.edge_n.any()
    np.testing.assert_allclose(load.faces_n, [0.0, 0.0, -2 * 0.3 * 1600.0 * area], atol=1e-12)


def test_the_same_cutting_model_gives_the_same_force_on_both_resolutions() -> None:
    # The geometry the model reads (the interface's top line) comes from the mesh: the
    # cell's resolution (0.025 m) and the envs' (0.05 m) give the same force while cutting.
    params = AponeurosisParams().cutting(beef_cutting())
    path = np.arange(-0.25, 0.25, 0.001)  # the edge's advance per control step, about
    fine = np.linalg.norm(_cut_along(_seam(0.025, params), path, CLEARANCE_M), axis=1)
    coarse = np.linalg.norm(_cut_along(_seam(0.05, params), path, CLEARANCE_M), axis=1)
    cutting = (fine > 0) | (coarse > 0)
    assert 9.0 <= fine[cutting].mean() <= 19.0
    assert coarse[cutting].mean() == pytest.approx(fine[cutting].mean(), rel=0.1)


def test_the_seam_toughness_and_force_scale_make_the_cutting_model() -> None:
    apo = AponeurosisParams(toughness_j_m2=200.0, force_scale=1.5)
    assert apo.cutting(beef_cutting()) == replace(beef_cutting(), toughness_j_m2=300.0)
    assert apo.cutting(None) == CuttingParams(toughness_j_m2=300.0)


@pytest.mark.parametrize(("line", "key", "message"), [
    ('knife_force = "saw"', "aponeurosis.knife_force", "must be one of 'cutting', 'curve'"),
    ("knife_force = 1", "aponeurosis.knife_force", "must be one of"),
    ("toughness_j_m2 = -5.0", "aponeurosis.toughness_j_m2", "must be > 0"),
])
def test_a_bad_knife_force_names_the_file_and_key(tmp_path: Path, line: str, key: str,
                                                  message: str) -> None:
    path = tmp_path / "s.toml"
    path.write_text(f"[aponeurosis]\n{line}\n")
    with pytest.raises(ScenarioError, match=message) as caught:
        load_scenario(path)
    assert caught.value.file == str(path) and caught.value.field == key


#: :func:`_short`'s result before ``knife_force`` existed (commit 612b92b, which had only the
#: curve), to the last digit.
OLD_SHORT = {
    "released_by_rule": {"knife": 0, "tearing": 0, "force": 6},
    "knife_force_peak_n": 11.170918665025923,
    "knife_force_cutting_mean_n": 5.613095872059539,
    "knife_force_split_n": {
        "bindings": {"peak": 1.8203856902379356, "mean": 0.1863207004115239},
        "flesh": {"peak": 3.6262521329371165, "mean": 0.5727161582314039},
        "edge": {"peak": 10.787515695623147, "mean": 4.9331022247640455},
    },
}


def _short(knife_force: str) -> Scenario:
    """A coarse cell whose knife cuts for about a second, no camera, no pull."""
    base = Scenario(tissue=MuscleShape(cell_size_m=0.05, length_m=0.3), end_s=4.5,
                    cut=CutPlan(speed_m_s=0.06), pull=PullPlan(enabled=False),
                    perception=PerceptionParams(enabled=False))
    return replace(base, aponeurosis=replace(base.aponeurosis, knife_force=knife_force))


def test_an_old_scenario_with_the_curve_gives_the_old_numbers() -> None:
    # The numbers of this cell before knife_force existed (the curve was the only force).
    result = Episode(_short("curve")).run()["result"]
    assert result["released_by_rule"] == OLD_SHORT["released_by_rule"]
    assert result["knife_force_peak_n"] == pytest.approx(OLD_SHORT["knife_force_peak_n"],
                                                         rel=1e-9)
    assert result["knife_force_cutting_mean_n"] == pytest.approx(
        OLD_SHORT["knife_force_cutting_mean_n"], rel=1e-9)
    split = result["knife_force_split_n"]
    for part, figures in OLD_SHORT["knife_force_split_n"].items():
        assert split[part] == pytest.approx(figures, rel=1e-9)
    assert split["faces"] == {"peak": 0.0, "mean": 0.0}


@pytest.mark.slow
def test_the_knife_force_while_cutting_is_the_same_at_both_resolutions() -> None:
    # The whole cell (hooked bindings, flesh contacts, edge, faces) at the cell's resolution
    # and the envs': the knife's force while cutting within 10 %.
    fine, coarse = (Episode(replace(_short("cutting"), end_s=9.0, tissue=MuscleShape(
        cell_size_m=size, length_m=0.3))).run()["result"] for size in (0.025, 0.05))
    assert coarse["knife_force_cutting_mean_n"] == pytest.approx(
        fine["knife_force_cutting_mean_n"], rel=0.1)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_default_episode_cuts_with_the_cutting_model(seed: int) -> None:
    # Issue 33's acceptance: every binding released, at most a tenth torn, and the knife's
    # force while cutting within what boning knives are published to meet (9 to 19 N).
    scenario = replace(load_scenario(DEFAULT_SCENARIO), seed=seed)
    assert scenario.aponeurosis.knife_force == "cutting"
    result = Episode(scenario).run()["result"]
    assert result["released_fraction"] == 1.0
    assert result["released_by_rule"]["tearing"] <= 0.1 * result["bindings"]
    assert 9.0 <= result["knife_force_cutting_mean_n"] <= 19.0
