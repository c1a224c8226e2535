"""`musclecell learn --address`: the envs as Ray actors on a two-node cluster started here
(the `cluster` fixture), the learner in the test's process: the same seeded run trains the
same policy as the envs in processes here, and a run whose env worker is killed finishes;
episodes played as Ray tasks (DAgger's) match those played here."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

import numpy as np
import psutil
import pytest

from cell.cli import main
from cell.learning import ppo
from cell.learning.baselines import PolicySpec
from cell.learning.evaluate import EpisodeTask, episode_runner
from cell.learning.hyper import LearnSettings, PPOHyper

pytest.importorskip("ray")

ENV_ID = "musclecell/Cut-v2"
#: Short, coarse episodes: 10 control steps on a short muscle pair.
ENV_KWARGS = {"time_limit_s": 0.2, "cell_size_m": 0.08, "options": {"tissue": {"length_m": 0.3}}}
HYPER = {"n_steps": 16, "batch_size": 16, "n_epochs": 2}


def _learn(out: Path, *options: str) -> dict[str, np.ndarray]:
    assert main(["learn", ENV_ID, "--envs", "2", "--steps", "64", "--seed", "7",
                 "--checkpoint-every", "1000", "--env-kwargs", json.dumps(ENV_KWARGS),
                 "--hyper", json.dumps(HYPER), "--out", str(out), "--quiet", *options]) == 0
    with np.load(out / "policy.npz") as weights:
        return dict(weights)


@pytest.mark.slow
def test_the_same_seeded_run_trains_the_same_policy_here_and_on_the_cluster(
        cluster: str, tmp_path: Path) -> None:
    here = _learn(tmp_path / "here")
    there = _learn(tmp_path / "cluster", "--address", cluster)
    assert sorted(here) == sorted(there)
    for name, weights in here.items():
        np.testing.assert_array_equal(weights, there[name], err_msg=name)
    normalization = [json.loads((tmp_path / run / "normalization.json").read_text())
                     for run in ("here", "cluster")]
    assert normalization[0] == normalization[1]


def _kill_an_env_worker(killed: list[int]) -> None:
    """SIGKILL one Ray worker that holds a training env (its process title)."""
    if killed:
        return
    for process in psutil.process_iter(["cmdline"]):
        if (process.info["cmdline"] or [""])[0].startswith("ray::EnvHost"):
            os.kill(process.pid, signal.SIGKILL)
            killed.append(process.pid)
            return


@pytest.mark.slow
def test_a_run_whose_env_worker_is_killed_replaces_it_and_finishes(
        cluster: str, tmp_path: Path) -> None:
    killed: list[int] = []
    settings = LearnSettings(ENV_ID, ENV_KWARGS, seed=0, envs=2, steps=96,
                             checkpoint_every=1000, address=cluster)
    # Called as the first rollout's steps are counted: the kill lands between rollouts.
    result = ppo.learn(settings, PPOHyper().with_overrides(HYPER), tmp_path / "run",
                       on_steps=lambda _steps: _kill_an_env_worker(killed))
    assert len(killed) == 1
    assert (result.steps, result.stopped_by) == (96, "steps")
    learned = json.loads((tmp_path / "run" / "learn.json").read_text())
    assert learned["steps"] == 96


@pytest.mark.slow
def test_episodes_played_as_ray_tasks_match_those_played_here(cluster: str) -> None:
    # DAgger's rounds play their episodes so (DaggerSettings.address).
    tasks = [EpisodeTask(ENV_ID, json.dumps(ENV_KWARGS), PolicySpec("random"), seed)
             for seed in (100000, 100001)]
    rows = {}
    for address in (None, cluster):
        with episode_runner(1, address=address) as run_tasks:
            rows[address] = [{k: v for k, v in row.items() if k != "wall_s"}
                             for row in run_tasks(tasks)]
    assert rows[None] == rows[cluster]


def test_an_unreachable_cluster_is_a_named_error_and_nothing_is_written(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    assert main(["learn", ENV_ID, "--steps", "8", "--out", str(out), "--quiet",
                 "--address", "127.0.0.1:1"]) == 2
    assert "--address: cannot reach 127.0.0.1:1" in capsys.readouterr().err
    assert not out.exists()
