"""Rollouts collected by the env processes (cell.learning.segments, cell.learning.segmentppo):
a segment plays through its episodes' ends and is the same for the same seed, the rewards are
scaled as VecNormalize scales them, and two envs train the same run twice."""

import json
from pathlib import Path

import numpy as np
import pytest

from cell.cli import main
from cell.learning.environments import make_segment_worker
from cell.learning.policyfile import ObservationNormalizer
from cell.learning.segments import Actor, SegmentRequest

ENV_ID = "musclecell/Cut-v2"
#: 10-step episodes on a short, coarse muscle pair.
ENV_KWARGS = {"time_limit_s": 0.2, "cell_size_m": 0.08, "options": {"tissue": {"length_m": 0.3}}}


def _request(worker, steps: int, seed: tuple[int, int]) -> SegmentRequest:
    size = worker.observation_space.shape[0]
    actions = worker.action_space.shape[0]
    actor = Actor([(np.zeros((actions, size), np.float32), np.full(actions, 0.3, np.float32))],
                  "Tanh", np.full(actions, -1.0, np.float32))
    normalize = ObservationNormalizer(np.zeros(size), np.ones(size), 10.0, 1e-8)
    return SegmentRequest(actor, normalize, steps, worker.action_space.low,
                          worker.action_space.high, seed)


def test_a_segment_plays_through_episode_ends_the_same_for_the_same_seed() -> None:
    worker = make_segment_worker(ENV_ID, ENV_KWARGS, 1)
    segments = []
    for _ in range(2):
        worker.reset(seed=7)
        segments.append(worker.collect(_request(worker, 12, (0, 0))))
    first, again = segments
    for name in ("observations", "actions", "rewards", "dones"):
        np.testing.assert_array_equal(getattr(first, name), getattr(again, name))
    assert np.flatnonzero(first.dones).tolist() == [9]  # a 10-step episode, then the next
    assert first.infos[9]["episode"]["l"] == 10
    assert first.infos[9]["episode"]["r"] == pytest.approx(float(first.rewards[:10].sum()))
    # The next world's first observation follows the end.
    assert not np.array_equal(first.observations[10], first.observations[9])


def test_rewards_are_scaled_as_vecnormalize_scales_them() -> None:
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from cell.learning.segmentppo import normalized_rewards

    rng = np.random.default_rng(0)
    rewards = rng.normal(size=(30, 2)).astype(np.float32)
    dones = rng.random((30, 2)) < 0.1
    import gymnasium as gym

    ours, theirs = (VecNormalize(DummyVecEnv([lambda: gym.make("Pendulum-v1")] * 2), gamma=0.9)
                    for _ in range(2))
    scaled = normalized_rewards(ours, rewards, dones)
    for t in range(len(rewards)):  # VecNormalize.step_wait's reward steps
        theirs._update_reward(rewards[t])
        theirs.returns[dones[t]] = 0
    np.testing.assert_allclose(ours.returns, theirs.returns)
    np.testing.assert_allclose(ours.ret_rms.var, theirs.ret_rms.var, rtol=1e-9)
    np.testing.assert_allclose(scaled, theirs.normalize_reward(rewards), rtol=1e-6)


@pytest.mark.slow
def test_two_envs_train_the_same_run_for_the_same_seed(tmp_path: Path) -> None:
    policies = []
    for name in ("a", "b"):
        out = tmp_path / name
        assert main(["learn", ENV_ID, "--envs", "2", "--steps", "64", "--out", str(out),
                     "--seed", "11", "--env-kwargs", json.dumps(ENV_KWARGS), "--hyper",
                     json.dumps({"n_steps": 16, "batch_size": 16, "n_epochs": 2})]) == 0
        with np.load(out / "policy.npz", allow_pickle=False) as arrays:
            policies.append({key: arrays[key] for key in arrays.files})
        assert (out / "episodes.csv").read_text().count("\n") == 1 + 6  # 10-step episodes
    assert policies[0].keys() == policies[1].keys()
    for key in policies[0]:
        np.testing.assert_array_equal(policies[0][key], policies[1][key])
