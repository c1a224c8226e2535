"""Learning Steer-v2 from the expert that steers on the true interface (DAgger): its settings
as named errors, a run's files and learning curve, a policy `evaluate` loads like PPO's, a run
started from a fixed policy that scores better afterwards; and the evaluation's tip-distance
column."""

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from cell.errors import LearningError
from cell.learning.dagger import DaggerSettings, normalization_json, normalizer_of, train
from cell.learning.paired import compare, comparison_markdown
from cell.learning.table import markdown, summarize
from envs.policies import TableSkimmingKnife

ENV_ID = "musclecell/Steer-v2"
#: 10-step episodes on a short, coarse muscle pair.
ENV_KWARGS = {"time_limit_s": 0.2, "cell_size_m": 0.08, "options": {"tissue": {"length_m": 0.3}}}


def test_bad_settings_are_named_errors() -> None:
    with pytest.raises(LearningError, match="expert"):
        DaggerSettings(expert="oracle")
    with pytest.raises(LearningError, match="episodes"):
        DaggerSettings(episodes=0)
    with pytest.raises(LearningError, match="--seed"):  # the evaluation's seeds are not trained on
        DaggerSettings(seed=99_990, rounds=2, episodes=8)
    assert list(DaggerSettings(seed=10, episodes=3).seeds(2)) == [16, 17, 18]


def test_the_frozen_statistics_are_written_as_evaluate_reads_them(tmp_path: Path) -> None:
    from cell.learning.policyfile import observation_normalizer, read_normalization
    from cell.outputs import write_json

    observations = np.array([[0.0, 1.0, 5.0], [2.0, 1.0, 5.001]])
    normalize = normalizer_of(observations)
    write_json(tmp_path / "normalization.json", normalization_json(normalize, 2))
    loaded = observation_normalizer(read_normalization(tmp_path))
    # The entries that hardly move are scaled by the least variance, not blown up.
    assert loaded(observations[0]) == pytest.approx([-1.0, 0.0, -0.05], abs=1e-4)


def test_the_saved_network_averages_the_rounds_ends_exponentially() -> None:
    import gymnasium as gym
    import torch
    from stable_baselines3.common.policies import ActorCriticPolicy

    from cell.learning.dagger import _averaged

    box = gym.spaces.Box(-1.0, 1.0, (3,), np.float32)
    policy = ActorCriticPolicy(box, box, lambda _: 1e-3, net_arch=[4])
    averaged = _averaged(policy, rounds=2)
    for value in (1.0, 3.0, 7.0):
        with torch.no_grad():
            for parameter in policy.parameters():
                parameter.fill_(value)
        averaged.update_parameters(policy)
    # The first end is taken whole, then each later one at weight 1/2.
    expected = ((1.0 * 0.5 + 3.0 * 0.5) * 0.5 + 7.0 * 0.5)
    for parameter in averaged.module.parameters():
        assert parameter.detach().numpy() == pytest.approx(np.full(parameter.shape, expected))
    assert _averaged(policy, rounds=0) is None
    with pytest.raises(LearningError, match="average_rounds"):
        DaggerSettings(average_rounds=-1)


@pytest.mark.slow
def test_a_run_writes_a_policy_that_evaluate_loads_and_its_learning_curve(
        tmp_path: Path) -> None:
    from cell.learning.baselines import load_learned
    from cell.learning.headroom import choose_learned
    from cell.learning.policyfile import read_policy

    settings = DaggerSettings(env_kwargs=ENV_KWARGS, rounds=2, episodes=1, fit_batches=3,
                              workers=1, net_arch=(8,), base="table-skimming-knife",
                              learned=(1,), average_rounds=2)
    record = train(settings, tmp_path)
    # The rounds' average is a policy of its own, and validation seeds choose between them.
    folders = [str(tmp_path), str(tmp_path / "average")]
    assert load_learned(folders[1]).env_id == ENV_ID
    choice = choose_learned(folders, range(300_300, 300_302), 1, ENV_KWARGS)
    assert choice["chosen"] in folders and len(choice["scores"]) == 2
    with (tmp_path / "learning_curve.csv").open(newline="") as file:
        curve = list(csv.DictReader(file))
    assert [row["played_by"] for row in curve] == ["expert", "learner"]
    assert [int(row["env_steps"]) for row in curve] == [10, 20]
    assert record["stopped_by"] == "rounds"
    saved = json.loads((tmp_path / "policy.json").read_text())
    assert saved["algorithm"] == "DAgger"
    assert saved["base_policy"] == {"name": "table-skimming-knife", "learned": [1]}
    policy = load_learned(str(tmp_path))
    obs = np.linspace(-1.0, 1.0, policy.network.observation_space.shape[0]).astype(np.float32)
    knife = TableSkimmingKnife()(obs)
    # The network steers; the knife's speed, depth and yaw are the servo's.
    assert policy.env_id == ENV_ID and policy(obs)[[0, 2, 3]] == pytest.approx(knife[[0, 2, 3]])
    with pytest.raises(LearningError, match="already holds a policy"):
        train(settings, tmp_path)
    saved["base_policy"]["learned"] = [4]
    (tmp_path / "policy.json").write_text(json.dumps(saved))
    with pytest.raises(LearningError, match=r"base_policy\.learned"):
        read_policy(tmp_path)


def _tip_mm(folder: Path, seeds: range) -> float:
    """The policy's mean tip distance on ``seeds``, played as the headroom table plays it (an
    unscored episode as 5 mm)."""
    from cell.learning.headroom import SteerEpisode, play

    tips = [play(SteerEpisode("learned", (), seed, learned=str(folder)))["tip_mean_mm"]
            for seed in seeds]
    return float(np.mean([5.0 if tip is None else tip for tip in tips]))


@pytest.mark.slow
def test_a_short_run_from_a_fixed_policy_steers_nearer_the_interface_on_fixed_seeds(
        tmp_path: Path) -> None:
    steering = {"base": "table-skimming-knife", "learned": (1,), "episodes": 4, "workers": 2}
    # The fixed policy: a plain clone of the expert's own episodes, which holds the offset it
    # commands, so it hardly steers.
    train(DaggerSettings(rounds=1, **steering), tmp_path / "clone")
    train(DaggerSettings(seed=4, rounds=2, init=str(tmp_path / "clone"), **steering),
          tmp_path / "dagger")
    seeds = range(99_000, 99_003)
    assert _tip_mm(tmp_path / "dagger", seeds) < _tip_mm(tmp_path / "clone", seeds)


def test_the_evaluation_shows_the_tip_distance_over_the_episodes_that_scored_it() -> None:
    rows = [{"policy": policy, "seed": seed, "success": True, "return": 1.0,
             "diverged": False, "protective_stop": False, "released_fraction": 1.0,
             "torn_fraction": 0.1, "knife_force_peak_n": 5.0, "flesh_damage_s": 0.0,
             "elapsed_s": 4.0, "tip_distance_mm": tip}
            for policy, tips in (("learned", (0.5, None, 0.7)), ("rule", (1.0, 1.2, 1.0)))
            for seed, tip in zip(range(3), tips, strict=True)]
    learned = summarize([row for row in rows if row["policy"] == "learned"])
    assert learned["tip_distance_mm"]["mean"] == pytest.approx(0.6)
    assert learned["tip_distance_mm"]["scored"] == 2
    assert "tip to interface (mm)" in markdown({"learned": learned}).splitlines()[0]
    comparison = compare(rows, "learned", "rule")
    assert comparison["tip_distance_mm"]["mean"] == pytest.approx(-0.4)
    assert comparison["tip_distance_mm"]["scored_on"] == 2
    assert "on the 2 seeds both scored" in comparison_markdown(comparison)


def test_the_headroom_refuses_a_learned_policy_of_another_env(tmp_path: Path) -> None:
    from cell.learning.dagger import _network
    from cell.learning.environments import make_env
    from cell.learning.headroom import SteerEpisode, play
    from cell.learning.policyfile import save_network

    env = make_env("musclecell/Cut-v2", ENV_KWARGS)
    observations = np.zeros((2, env.observation_space.shape[0]))
    save_network(tmp_path, _network(DaggerSettings(net_arch=(4,)), env),
                 normalization_json(normalizer_of(observations), 2), "musclecell/Cut-v2",
                 "DAgger", 2, 1)
    with pytest.raises(LearningError, match="policy is of musclecell/Cut-v2, not of "
                       "musclecell/Steer-v2 or musclecell/Steer-v1"):
        play(SteerEpisode("learned", (), 0, learned=str(tmp_path)))
