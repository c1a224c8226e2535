"""Whole episodes on a coarse cell: the cut, the pull, tracking, determinism, the recording."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pytest

from cell.cli import main
from cell.errors import OutputError
from cell.perception.params import PerceptionParams
from cell.robots.names import KNIFE_BLADE_GEOM
from cell.sim.assembly import build_scene
from cell.sim.episode import Episode
from cell.sim.recording import EpisodeRecorder
from cell.sim.scenario import AponeurosisParams, Scenario, SensorParams, load_scenario
from cell.tissue.geometry import MuscleShape
from controllers.gripper import PullPlan
from controllers.knife import CutPlan
from controllers.steering import SteeringParams
from tests.coarse import coarse
from tests.paths import PROJECT_ROOT


@pytest.fixture(scope="module")
def full_episode() -> dict:
    return Episode(coarse()).run()["result"]


def test_the_knife_follows_the_perceived_guideline(full_episode: dict) -> None:
    perception = full_episode["perception"]
    assert perception["guideline_to_true_top_line_xy_m"]["mean"] <= 0.005
    assert perception["guideline_to_true_top_line_xy_m"]["max"] <= 0.015
    assert perception["coverage_of_true_top_line"] > 0.8


def test_the_knife_steers_by_its_lateral_load_within_its_bound(full_episode: dict) -> None:
    steering = full_episode["steering"]
    bound = SteeringParams().max_lean_change
    assert -bound <= steering["lean_change_min"] <= steering["lean_change"] \
        <= steering["lean_change_max"] <= bound
    # The generic model's own shape: the load holds the lean near the plan's.
    assert abs(steering["lean_change"]) < 0.05


def test_cut_and_pull_separate_the_muscles(full_episode: dict) -> None:
    assert full_episode["released_fraction"] >= 0.95
    assert full_episode["muscles_apart"]
    assert full_episode["gap_m"]["median"] > 0.05
    assert full_episode["released_by_rule"]["force"] > 0
    assert full_episode["grasped_vertices"] > 0


def test_the_knife_feels_the_measured_cutting_force(full_episode: dict) -> None:
    # The default releases by force: the F/T sensor reads the measured order (5 to 20 N,
    # not the 1 N of knife release), most bindings are cut by the rule, and the load splits
    # into hooked bindings, flesh on the blade, the edge's resistance and the faces' friction
    # of the material's cutting model.
    assert full_episode["knife_force_peak_n"] > 3.0
    released = full_episode["released_by_rule"]
    assert released["force"] > released["tearing"]
    split = full_episode["knife_force_split_n"]
    assert set(split) == {"bindings", "flesh", "edge", "faces"}
    assert split["bindings"]["peak"] > 0.0 and split["edge"]["mean"] > 1.0
    assert split["faces"]["mean"] > 0.1
    assert full_episode["knife_force_cutting_mean_n"] > 1.0


def test_the_knife_force_sensor_feels_the_flesh_pressing_on_the_blade() -> None:
    # MuJoCo's force sensors leave the flex contacts out; the cell's F/T reading puts them
    # back, so that it balances every load on the knife (the weight is tared; the knife's
    # inertia is what is left).
    episode = Episode(coarse(perception=PerceptionParams(enabled=False),
                             sensors=SensorParams(force_noise_n=0.0)))
    plan, sim = episode.plan(), episode.sim
    blade = sim.model.geom(KNIFE_BLADE_GEOM).id
    knife, site = sim.model.geom_bodyid[blade], sim.model.sensor("knife/force").objid[0]
    flesh_n, unbalanced_n = [], []
    while sim.time_s < plan.cut_window_s.start_s + 3.0:
        t_next = sim.time_s + episode.control_dt_s
        episode.control_step(plan, plan.knife.sample(t_next), plan.pull.sample(t_next))
        flesh, _ = sim.flex_contact_load(np.array([knife]), np.zeros(3))
        loads = flesh + sim.data.xfrc_applied[knife, :3]  # contacts, bindings, the edge
        reading = sim.data.site_xmat[site].reshape(3, 3) @ sim.read("knife/force")
        flesh_n.append(np.linalg.norm(flesh))
        unbalanced_n.append(np.linalg.norm(reading + loads))
    flesh_n, unbalanced_n = np.array(flesh_n), np.array(unbalanced_n)
    pressed = flesh_n > 0.5
    assert pressed.sum() > 10
    assert np.median(unbalanced_n[pressed]) < 0.2 * np.median(flesh_n[pressed])


def test_knife_tip_tracks_the_path_with_physics_on(full_episode: dict) -> None:
    assert full_episode["knife_tracking_error_m"]["median"] <= 0.002


def test_camera_arm_holds_its_pose_while_the_others_work(full_episode: dict) -> None:
    assert full_episode["held_arm_drift_m"]["camera"] < 0.002


@pytest.mark.slow  # a whole episode
def test_cut_over_half_the_interface_releases_only_that_half_by_knife() -> None:
    # The knife rule (a scenario option), on the generator's interface: the coarse test
    # mesh's facets are too rough for the perceived interface to keep the blade off the
    # muscles.
    scenario = coarse(cut=CutPlan(speed_m_s=0.06, cut_fraction=0.5),
                      pull=PullPlan(enabled=False), perception=PerceptionParams(enabled=False),
                      aponeurosis=AponeurosisParams(release_rules=("knife", "tearing")))
    episode = Episode(scenario)
    summary = episode.run()["result"]
    apo = episode.scene.aponeurosis
    released = ~apo.bound
    assert summary["released_by_rule"] == {"knife": int(released.sum()), "tearing": 0, "force": 0}
    pair_x, _, pair_z = episode.scene.mesh.round.points[apo.pairs[:, 0]].T
    middle = 0.5 * (pair_x.min() + pair_x.max())
    reached = pair_z > scenario.layout.table_height_m + scenario.cut.table_clearance_m
    assert released[(pair_x < middle - 0.03) & reached].all()
    assert not released[pair_x > middle + 0.03].any()
    assert summary["held_arm_drift_m"]["gripper"] < 0.002


@pytest.mark.slow  # a whole episode
def test_pulling_with_the_knife_away_releases_by_tearing_only() -> None:
    scenario = coarse(cut=CutPlan(enabled=False), pull=PullPlan(speed_m_s=0.04))
    summary = Episode(scenario).run()["result"]
    assert summary["released_by_rule"]["knife"] == summary["released_by_rule"]["force"] == 0
    assert summary["released_by_rule"]["tearing"] > 0
    assert summary["held_arm_drift_m"]["knife"] < 0.002


@pytest.mark.slow  # a whole episode
def test_tearing_off_keeps_the_uncut_bindings() -> None:
    scenario = coarse(cut=CutPlan(enabled=False),
                      aponeurosis=AponeurosisParams(release_rules=("knife",)), end_s=6.0)
    summary = Episode(scenario).run()["result"]
    assert summary["released_fraction"] == 0.0


@pytest.mark.slow  # two episodes; the default run's check: tests/envs/test_envs.py
def test_same_seed_gives_the_same_summary_twice() -> None:
    scenario = coarse(end_s=5.0, seed=7)
    first = Episode(scenario).run()["result"]
    second = Episode(scenario).run()["result"]
    assert json.dumps(first, sort_keys=True) == json.dumps(second, sort_keys=True)
    other = Episode(replace(scenario, seed=8)).run()["result"]
    assert other["knife_force_peak_n"] != first["knife_force_peak_n"]  # noise follows the seed


def test_cli_run_writes_a_recording_rerun_verifies(tmp_path: Path) -> None:
    scenario_file = tmp_path / "short.toml"
    scenario_file.write_text(
        '[scenario]\nname = "short"\nend_s = 1.5\n[tissue]\ncell_size_m = 0.05\n'
        "[recording]\nrate_hz = 10.0\ncamera_rate_hz = 2.0\n")
    rrd = tmp_path / "short.rrd"
    summary = tmp_path / "summary.json"
    code = main(["run", str(scenario_file), "--rerun", str(rrd), "--out", str(summary),
                 "--quiet"])
    assert code == 0
    assert json.loads(summary.read_text())["result"]["scenario"] == "short"
    rerun = shutil.which("rerun", path=str(Path(sys.executable).parent))
    assert rerun is not None, "the rerun CLI ships with rerun-sdk"
    verify = subprocess.run([rerun, "rrd", "verify", str(rrd)], capture_output=True, text=True,
                            check=False)
    assert verify.returncode == 0, verify.stderr
    assert not list(tmp_path.glob(".*.tmp"))


def test_tracking_errors_are_measured_during_the_cut_only(full_episode: dict) -> None:
    errors = full_episode["knife_tracking_error_m"]
    assert 0.0 < errors["median"] <= errors["p95"] <= errors["max"] < 0.01
    assert np.isfinite(full_episode["knife_force_peak_n"])


@pytest.mark.slow  # a whole episode
def test_force_rule_alone_cuts_with_the_hooked_bindings() -> None:
    # No edge resistance (the curve's share at the edge none): hooked bindings resist the
    # blade until they are cut, and the F/T sensor reads them.
    scenario = coarse(aponeurosis=AponeurosisParams(release_rules=("force",), knife_force="curve",
                                                    edge_share=0.0),
                      pull=PullPlan(enabled=False))
    summary = Episode(scenario).run()["result"]
    assert summary["released_by_rule"]["force"] > 0
    assert summary["released_by_rule"]["knife"] == summary["released_by_rule"]["tearing"] == 0
    assert summary["knife_force_split_n"]["edge"]["peak"] == 0.0
    assert summary["knife_force_peak_n"] > 1.0


@pytest.mark.slow
def test_a_meat_twenty_times_stiffer_runs_the_default_episode_unchanged() -> None:
    # Only the material changes (the implicit tissue step needs no shorter step): the default
    # episode, at the default resolution, still separates the muscles to the end.
    scenario = load_scenario(PROJECT_ROOT / "scenarios" / "default.toml")
    meat = scenario.material
    stiffer = replace(meat, **{name: replace(getattr(meat, name), coefficients=tuple(
        20.0 * c for c in getattr(meat, name).coefficients))
        for name in ("longitudinal", "transverse")})
    result = Episode(replace(scenario, material=stiffer)).run()["result"]
    assert result["released_fraction"] >= 0.95
    assert result["muscles_apart"]


@pytest.mark.slow
def test_the_papers_stiff_material_runs_the_default_episode() -> None:
    # scenarios/paper_material.toml, 10 to 25 times stiffer than the default meat, on a seed
    # where the blade's fully resolved contacts made the stiff flesh chatter until the
    # tissue ran away (above 20 m/s at 5 s): cell.robots.tools.BLADE_SOLIMP.
    scenario = load_scenario(PROJECT_ROOT / "scenarios" / "paper_material.toml")
    result = Episode(replace(scenario, seed=2)).run()["result"]
    assert result["released_fraction"] >= 0.95
    assert result["muscles_apart"]


def test_the_cut_is_scored_against_the_true_interface(full_episode: dict) -> None:
    tip = full_episode["knife_tip_to_true_interface_m"]
    assert 0.0 < tip["mean"] <= tip["max"] and tip["mean"] <= 0.003
    assert [p["pass"] for p in tip["passes"]] == [0]
    damage = full_episode["flesh_damage"]
    bindings = full_episode["bindings"]
    assert damage["bindings_torn"] == full_episode["released_by_rule"]["tearing"]
    assert damage["torn_fraction"] == pytest.approx(damage["bindings_torn"] / bindings)
    assert damage["blade_volume_in_flesh_m3"] >= 0.0


def test_a_closed_or_aborted_recording_refuses_more_frames(tmp_path: Path) -> None:
    scene = build_scene(Scenario(tissue=MuscleShape(cell_size_m=0.05)))
    data = mujoco.MjData(scene.model)
    mujoco.mj_forward(scene.model, data)
    kept = EpisodeRecorder(tmp_path / "kept.rrd", scene, "kept")
    kept.log_frame(data, knife_tip_m=np.zeros(3), scalars={})
    assert kept.close() == tmp_path / "kept.rrd"
    kept.abort()  # after close: the recording stays
    dropped = EpisodeRecorder(tmp_path / "dropped.rrd", scene, "dropped")
    dropped.abort()
    for recorder in (kept, dropped):
        with pytest.raises(OutputError, match=r"\.rrd: the recording is closed"):
            recorder.log_frame(data, knife_tip_m=np.zeros(3), scalars={})
    with pytest.raises(OutputError):
        kept.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.rrd"]
