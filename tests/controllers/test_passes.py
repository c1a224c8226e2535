"""The cut in passes: each deeper, the camera looking between them, the interface estimate
learning from what it sees, every look in the summary and the recording."""

from __future__ import annotations

import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cell.perception.interface import SeenInterface
from cell.sim.episode import Episode
from cell.sim.scenario import Scenario
from cell.tissue.geometry import MuscleShape
from controllers.gripper import PullPlan
from controllers.knife import CutPlan, plan_cut, plan_passes

PATH = np.array([[-0.2, 0.0, 0.66], [0.0, 0.01, 0.67], [0.2, 0.0, 0.66]])


def _prior(x_m: np.ndarray, z_m: np.ndarray) -> np.ndarray:
    """An interface through y = 0 at the top (z 0.66 m), leaning 0.1."""
    return 0.1 * (np.asarray(z_m) - 0.66) + 0.0 * np.asarray(x_m)


def test_each_pass_cuts_deeper_and_the_camera_looks_between_them() -> None:
    passes = plan_passes(PATH, CutPlan(passes=3, depth_m=0.03), 0.6, 0.0,
                         PATH[0] + [0.0, 0.0, 0.1], np.eye(3))
    assert passes.depths_m == pytest.approx((0.01, 0.02, 0.03))
    lowest = [path[1:-1, 2].min() for path in passes.cut_paths_m]
    assert lowest[0] > lowest[1] > lowest[2]
    for (_, end), look, (start, _) in zip(passes.windows_s, passes.looks_s,
                                          passes.windows_s[1:], strict=False):
        assert end < look < start
        assert passes.pass_at(look) is None
    assert passes.pass_at(passes.windows_s[1].start_s + 0.1) == 1


def test_the_default_depth_reaches_the_table_clearance_under_any_top() -> None:
    clearance = CutPlan().table_clearance_m
    for rise_m in (0.0, 0.03):  # meat 3 cm taller: the cut still goes down to the table
        path = PATH + np.array([0.0, 0.0, rise_m])
        passes = plan_passes(path, CutPlan(passes=2), 0.6, 0.0, path[0] + [0.0, 0.0, 0.1],
                             np.eye(3))
        first, last = (cut[1:-1, 2] for cut in passes.cut_paths_m)
        np.testing.assert_allclose(last, 0.6 + clearance)
        # the first pass halfway down from the guideline wherever the top lies
        np.testing.assert_allclose(first, 0.5 * (path[:, 2] + 0.6 + clearance))


def test_one_pass_is_the_single_cut() -> None:
    trajectory, path, window = plan_cut(PATH, CutPlan(), 0.6, 0.0, PATH[0] + [0, 0, 0.1],
                                        np.eye(3))
    passes = plan_passes(PATH, CutPlan(), 0.6, 0.0, PATH[0] + [0, 0, 0.1], np.eye(3))
    np.testing.assert_array_equal(path, passes.cut_paths_m[0])
    assert window == passes.window_s and passes.looks_s == ()
    assert trajectory.end_s == passes.trajectory.end_s


def test_a_deeper_look_teaches_the_estimate_the_true_lean() -> None:
    def truth(x_m: np.ndarray, z_m: np.ndarray) -> np.ndarray:
        return 0.003 + 0.2 * (np.asarray(z_m) - 0.66) + 0.0 * np.asarray(x_m)

    x = np.linspace(-0.2, 0.2, 9)
    top = np.stack([x, truth(x, 0.66), np.full_like(x, 0.66)], axis=1)
    opened = np.stack([x, truth(x, 0.63), np.full_like(x, 0.63)], axis=1)
    first = SeenInterface((top,), _prior)
    learned = first.seen(opened)
    deep = np.full_like(x, 0.60)
    before = np.abs(first(x, deep) - truth(x, deep)).max()
    after = np.abs(learned(x, deep) - truth(x, deep)).max()
    assert before == pytest.approx(0.006, abs=1e-6)  # the prior's lean, 6 cm down
    assert after < before / 4
    assert learned.deepest_m() == pytest.approx(0.03)


def test_the_episode_plans_the_passes_and_the_pull_spans_them() -> None:
    scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05), cut=CutPlan(passes=2))
    plan = Episode(scenario).plan()
    assert len(plan.passes.windows_s) == 2 and len(plan.passes.looks_s) == 1
    assert plan.cut_window_s == plan.passes.window_s
    assert plan.schedule.pull_end_s > plan.passes.windows_s[-1].end_s


@pytest.mark.slow
def test_a_two_pass_episode_records_every_look(tmp_path: Path) -> None:
    scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05),
                        cut=CutPlan(passes=2, speed_m_s=0.06), pull=PullPlan(speed_m_s=0.04))
    scenario = replace(scenario, seed=11)
    rrd = tmp_path / "passes.rrd"
    summary = Episode(scenario).run(rerun_path=rrd)
    result = summary["result"]
    tip = result["knife_tip_to_true_interface_m"]
    assert [p["pass"] for p in tip["passes"]] == [0, 1]
    assert all(p["samples"] > 0 for p in tip["passes"])
    assert tip["mean"] <= 0.003
    [update] = result["perception"]["updates"]
    assert update["after_pass"] == 0 and update["perception_s"] < 0.3
    assert len(summary["timing"]["perception_s"]) == 2
    first, last = (p["depth_m"] for p in result["passes"])
    assert last == pytest.approx(2.0 * first)  # half way down, then to the table's clearance
    rerun = shutil.which("rerun", path=str(Path(sys.executable).parent))
    assert rerun is not None
    verify = subprocess.run([rerun, "rrd", "verify", str(rrd)], capture_output=True,
                            text=True, check=False)
    assert verify.returncode == 0, verify.stderr
