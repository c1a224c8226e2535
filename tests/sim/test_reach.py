"""Before any simulation, a plan the arms cannot follow is refused naming the arm, the waypoint
and the joint; arms of other makers, given as robot files, run the default episode."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cell.errors import ReachError
from cell.sim.episode import Episode
from cell.sim.reach import check_plan
from cell.sim.scenario import Scenario, load_scenario
from cell.tissue.geometry import MuscleShape
from controllers.trajectory import CartesianTrajectory, Waypoint
from tests.refusals import refused
from tests.robotarms import arms_scenario, write_seven_axis, write_ur5e

_COARSE = Scenario(tissue=MuscleShape(cell_size_m=0.05))


def test_an_arm_placed_out_of_reach_is_refused_and_nothing_runs(tmp_path: Path) -> None:
    scenario = tmp_path / "far.toml"
    scenario.write_text("[tissue]\ncell_size_m = 0.05\n\n"
                        "[layout]\nknife_arm_base = [0.0, -2.6, 0.0, 90.0]\n")
    message = refused(tmp_path, "run", "far.toml", "--out", "far.json",
                      words=("arms.knife", "viper_s1700d", "waypoint ready", "knife_arm/joint"))
    assert "mm" in message


def test_a_waypoint_beyond_the_arm_is_named_with_its_joint() -> None:
    episode = Episode(_COARSE)
    position_m, rotation = episode.ik.site_pose("knife/tip")
    far = CartesianTrajectory(0.0, position_m, rotation, [
        Waypoint(position_m + np.array([0.0, 0.0, 0.05]), rotation, speed_m_s=0.05),
        Waypoint(position_m + np.array([0.0, 0.0, 3.0]), rotation, speed_m_s=0.05)])
    q_before = episode.ik.configuration.q.copy()
    with pytest.raises(ReachError, match=r"waypoint 2 .*knife_arm/joint\d") as refusal:
        check_plan(episode.ik.configuration, episode.arms, {"knife": far})
    assert refusal.value.field == "arms.knife"
    np.testing.assert_array_equal(episode.ik.configuration.q, q_before)


def test_the_default_plan_is_within_reach() -> None:
    episode = Episode(_COARSE)
    plan = episode.plan()
    check_plan(episode.ik.configuration, episode.arms, {"knife": plan.knife,
                                                        "gripper": plan.pull})


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["xml", "urdf"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_ur5e_and_a_seven_axis_arm_run_the_default_episode(tmp_path: Path, kind: str,
                                                              seed: int) -> None:
    """The UR5e (MJCF or URDF) cuts and a seven-axis MJCF arm pulls: both on pedestals beside
    the table (:data:`tests.robotarms.UR5E_BASE`), their reach being half the Vipers'."""
    write_ur5e(tmp_path, kind)
    write_seven_axis(tmp_path)
    scenario = load_scenario(arms_scenario(tmp_path, f"ur5e.{kind}"))
    summary = Episode(replace(scenario, seed=seed)).run()
    result = summary["result"]
    assert result["released_fraction"] >= 0.95
    assert result["knife_tip_to_true_interface_m"]["mean"] <= 0.003
    assert summary["arms"]["knife_arm"] == {"name": "ur5e", "source": f"ur5e.{kind}",
                                            "joints": 6}
    assert summary["arms"]["pull_arm"]["joints"] == 7
    json.dumps(summary)


def test_a_camera_arm_out_of_reach_is_named() -> None:
    far = replace(_COARSE.layout, camera_arm_base=(2.5, 0.3, 0.6, 180.0))
    with pytest.raises(ReachError, match=r"kuka_lwr4 .*waypoint ready.*camera_arm/joint"):
        Episode(replace(_COARSE, layout=far))
