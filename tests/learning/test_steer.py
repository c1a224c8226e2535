"""The Steer task: its knife path planned off the true interface by the drawn perception
error, the tip scored against the true interface at the episode's end, its settings checked,
its baselines (no steering, the steering rule, the ceiling on the true interface), and
Steer-v2's low-passed knife force."""

import numpy as np
import pytest

import envs
from cell.errors import InputError
from envs.policies import SteeringKnife, TableSkimmingKnife, true_interface_policy
from envs.steer import PathError, SteerEnv, make_steer_v2

#: 10-step episodes on a short, coarse muscle pair.
ENV_KWARGS = {"time_limit_s": 0.2, "cell_size_m": 0.08, "options": {"tissue": {"length_m": 0.3}}}


def test_the_path_is_planned_off_the_true_interface_and_the_tip_scored_against_it() -> None:
    env = SteerEnv(**ENV_KWARGS)
    obs, _ = env.reset(seed=4)
    assert set(env.path_error) == {"across_m", "entry_across_m", "entry_height_m", "lean"}
    tip = env._reading.tip_m
    true_y = float(env.episode.scene.mesh.interface_y(tip[:1], tip[2:])[0])
    perceived_y = env._perceived.interface_y(tip[:1], tip[2:])[0]
    across_y = env._knife.path_pose()[1][1, 1]  # the path's across axis, world y part
    assert env.across_to_interface_m() == pytest.approx((true_y - perceived_y) * across_y)
    assert env.across_to_interface_m() != 0.0
    policy, done, steps = TableSkimmingKnife(limits=env.limits), False, 0
    while not done:
        obs, _, terminated, truncated, info = env.step(policy(obs))
        done, steps = terminated or truncated, steps + 1
        if not done:
            assert info["reward_terms"]["off_interface"] <= 0.0
    assert steps == 10 and info["path_error"] == env.path_error
    assert info["tip_distance_mean_m"] is None or 0.0 <= info["tip_distance_mean_m"] < 0.05


def test_bad_settings_are_named_errors() -> None:
    with pytest.raises(InputError, match="steer"):
        SteerEnv(steer={"path_errors": {}}, **ENV_KWARGS)
    with pytest.raises(InputError, match="fade_m"):
        PathError(fade_m=0.0)
    assert SteerEnv(steer={"path_error": {"lean": 0.0}}, **ENV_KWARGS).steer.path_error.lean == 0.0
    with pytest.raises(InputError, match=r"steer\.load_filters_s"):
        SteerEnv(steer={"load_filters_s": [0.1, 0.0]}, **ENV_KWARGS)


def test_v2_adds_the_knife_force_low_passed_to_v1_s_observation_and_plays_v1_s_rollout() -> None:
    old, new = SteerEnv(**ENV_KWARGS), make_steer_v2(**ENV_KWARGS)
    assert new.observation_names[:35] == old.observation_names == envs.OBSERVATION_NAMES
    assert new.observation_names[35:] == tuple(
        f"knife_f{axis}_lowpass_{tau}s" for tau in ("0.1", "0.5") for axis in "xyz")
    force = slice(envs.OBSERVATION_NAMES.index("knife_fx"),
                  envs.OBSERVATION_NAMES.index("knife_fz") + 1)
    (old_obs, _), (new_obs, _) = old.reset(seed=5), new.reset(seed=5)
    assert new.observation_space.contains(new_obs) and new_obs.shape == (41,)
    np.testing.assert_array_equal(new_obs[35:38], new_obs[force])  # starts at the reading
    action = np.array([1.0, 0.2, 0.0, 0.0], np.float32)
    for _ in range(5):
        before = new_obs
        (old_obs, old_reward, *_), (new_obs, new_reward, *_) = old.step(action), new.step(action)
        np.testing.assert_array_equal(new_obs[:35], old_obs)
        assert new_reward == old_reward
        for start, tau_s in ((35, 0.1), (38, 0.5)):  # a step towards the reading, not past it
            gain = 0.02 / (tau_s + 0.02)
            np.testing.assert_allclose(new_obs[start:start + 3], before[start:start + 3]
                                       + gain * (new_obs[force] - before[start:start + 3]),
                                       atol=1e-6)


@pytest.mark.slow  # episodes; Cut's check runs by default (test_randomization.py)
def test_check_env_passes_on_v2() -> None:
    from gymnasium.utils.env_checker import check_env

    check_env(make_steer_v2(**ENV_KWARGS), skip_render_check=True)


def test_the_rule_integrates_the_load_across_into_the_commanded_offset() -> None:
    names = envs.OBSERVATION_NAMES
    obs = np.zeros(len(names), np.float32)
    obs[names.index("path_progress")], obs[names.index("knife_fy")] = 0.5, 0.3
    obs[names.index("command_across_cm")] = 0.2  # 2 mm commanded so far
    policy = SteeringKnife(load_sign=-1.0, dead_band_n=0.0, weak_side_gain=1.0)
    action = policy(obs)
    wanted_m = 0.002 + policy.gain_m_per_n_s * 3.0 * policy.dt_s
    assert action[1] == pytest.approx(wanted_m / policy.limits.knife_max_across_m)
    obs[names.index("path_progress")] = 0.05  # the entry: the load does not count
    assert policy(obs)[1] == pytest.approx(0.002 / policy.limits.knife_max_across_m)


@pytest.mark.slow
def test_the_ceiling_runs_nearer_the_true_interface_than_no_steering() -> None:
    scores = {}
    for name in ("none", "ceiling"):
        env = SteerEnv(steer={"path_error": {"across_m": 0.003, "clip": 1.0}})
        obs, _ = env.reset(seed=2)
        policy = (true_interface_policy(env) if name == "ceiling"
                  else TableSkimmingKnife(limits=env.limits))
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(policy(obs))
            done = terminated or truncated
        scores[name] = info["tip_distance_mean_m"]
    assert scores["ceiling"] < 0.5 * scores["none"]


def test_the_headroom_summary_scores_the_tip_over_the_episodes_that_scored_it() -> None:
    from cell.learning.headroom import RULE_GRID, _summary, rule_settings

    assert len(rule_settings()) == np.prod([len(values) for values in RULE_GRID.values()])
    rows = [{"success": ok, "tip_mean_mm": tip, "tip_max_mm": tip, "torn_fraction": 0.1,
             "elapsed_s": 1.0} for ok, tip in ((True, 1.0), (True, 3.0), (False, None))]
    summary = _summary(rows)
    assert summary["tip_unscored"] == 1 and summary["tip_mean_mm"]["mean"] == 2.0
    assert summary["successes"] == 2 and summary["torn_fraction"]["mean"] == pytest.approx(0.1)


def test_the_paired_cycle_time_counts_only_the_seeds_both_policies_completed() -> None:
    from cell.learning.headroom import report_of, summary_lines

    def row(policy: str, seed: int, ok: bool, tip: float | None, time_s: float) -> dict:
        return {"policy": policy, "seed": seed, "success": ok, "tip_mean_mm": tip,
                "tip_max_mm": tip, "torn_fraction": 0.0, "elapsed_s": time_s}

    # Seed 2: the rule's knife stops at the entry (0.4 s), which is no faster cycle.
    rows = [row("rule", 1, True, 1.0, 6.0), row("rule", 2, False, None, 0.4),
            row("rule", 3, True, 2.0, 5.0), row("learned", 1, True, 0.5, 6.1),
            row("learned", 2, True, 0.7, 6.0), row("learned", 3, True, 1.0, 5.1)]
    paired = report_of(rows, {})["paired"]["learned - rule"]
    assert paired["cycle_time_on"] == 2 and paired["cycle_time_s"]["mean"] == pytest.approx(0.1)
    assert paired["elapsed_s"]["mean"] == pytest.approx(1.9333, abs=1e-3)
    assert paired["tip_scored_on"] == 2 and paired["tip_mean_mm"]["mean"] == pytest.approx(-0.75)
    assert "cycle time +0.10" in summary_lines(report_of(rows, {}))[-1]
