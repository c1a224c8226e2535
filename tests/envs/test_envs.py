"""The Gymnasium envs: API conformance, determinism, clipping, options, divergence, baselines."""

from __future__ import annotations

from collections.abc import Callable

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import envs
from cell.errors import InputError
from cell.sim.scenario import Scenario
from cell.tissue.shape import MuscleShape
from envs import CutEnv, MuscleSeparationEnv, PullEnv, RewardParams, apply_options
from envs.observation import Reading
from envs.policies import HoldThenPullAway, TableSkimmingKnife
from envs.reward import reward_terms
from tests.marks import slow_but

#: Pull shares the separation env's code: its whole episodes run with ``-m slow``.
SEPARATION_NOT_PULL = slow_but({MuscleSeparationEnv}, [MuscleSeparationEnv, PullEnv],
                               ids=lambda env_class: env_class.__name__)


# Cut's check: tests/envs/test_randomization.py (with its drawn worlds).
@pytest.mark.parametrize("env_class", SEPARATION_NOT_PULL)
def test_check_env_passes(env_class: type[MuscleSeparationEnv]) -> None:
    env = env_class(time_limit_s=1.0)
    check_env(env, skip_render_check=True)
    env.close()


def test_make_after_import_and_render() -> None:
    assert all(env_id in gym.registry for env_id in envs.CURRENT_IDS)
    env = gym.make("musclecell/Cut-v2", render_mode="rgb_array", time_limit_s=0.5)
    env.reset(seed=1)
    frame = env.render()
    assert frame.shape == (240, 640, 3) and frame.dtype == np.uint8 and frame.any()
    env.close()


def test_same_seed_same_episode() -> None:
    def rollout() -> tuple[np.ndarray, list[float]]:
        env = CutEnv(time_limit_s=1.0)
        first, _ = env.reset(seed=5)
        env.action_space.seed(5)
        rewards = [env.step(env.action_space.sample())[1] for _ in range(20)]
        return first, rewards

    (obs_a, rewards_a), (obs_b, rewards_b) = rollout(), rollout()
    np.testing.assert_array_equal(obs_a, obs_b)
    assert rewards_a == rewards_b


def test_out_of_range_actions_are_clipped_and_counted() -> None:
    env = CutEnv(time_limit_s=1.0)
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([3.0, -2.0, 0.5, 0.0], dtype=np.float32))
    assert info["clipped_actions"] == 2
    assert env._knife.across_m == pytest.approx(-env.limits.knife_across_speed_m_s * 0.02)


def test_knife_offsets_go_to_the_place_an_action_wants_at_the_speed_limit() -> None:
    env = CutEnv(time_limit_s=1.0, randomize=False)
    env.reset(seed=0)
    limits = env.limits
    for _ in range(40):  # 0.8 s at 20 mm/s: there by 15 mm, then held
        env.step(np.array([0.5, 0.0, 0.5, 0.0], np.float32))
    assert env._knife.depth_m == pytest.approx(0.5 * limits.knife_max_depth_m)
    noise = np.random.default_rng(0).normal(0.0, 0.6, (50, 4)).astype(np.float32)
    depths = []
    for action in np.clip(noise + np.array([0.5, 0.0, 0.5, 0.0]), -1, 1):
        env.step(action)
        depths.append(env._knife.depth_m)
    # Noise on a place averages out under the speed limit; on a speed it would random-walk.
    assert np.abs(np.array(depths) - 0.5 * limits.knife_max_depth_m).max() < 0.004


@pytest.mark.slow  # a whole episode
def test_a_pull_timed_by_the_plans_clock_tears_ahead_of_a_slow_knife() -> None:
    slow = {"knife_pace": 0.6}
    _, _, clock = _run(PullEnv(randomize=False, options=slow), "scripted")
    _, _, pace = _run(PullEnv(randomize=False, options=slow), HoldThenPullAway())
    assert not clock["success"] and clock["torn_fraction"] > envs.PULL_TASK.max_torn_fraction
    assert pace["success"] and pace["torn_fraction"] < 0.5 * clock["torn_fraction"]


@pytest.mark.parametrize("action", [np.zeros(3), np.zeros((2, 4)), [0.0] * 7, "fast"])
def test_a_wrongly_shaped_action_is_refused_by_name(action: object) -> None:
    env = CutEnv(time_limit_s=1.0)
    env.reset(seed=0)
    with pytest.raises(InputError, match=r"action: expected"):
        env.step(action)
    env.step(np.zeros((1, 4)))  # a batch of one is the action


def test_bad_reset_option_names_the_key() -> None:
    env = CutEnv(time_limit_s=1.0)
    with pytest.raises(InputError, match="stiffnes_n_m"):
        env.reset(seed=0, options={"stiffnes_n_m": 80.0})
    with pytest.raises(InputError, match=r"tissue\.cell_size_m"):
        env.reset(seed=0, options={"tissue": {"cell_size_m": 0.1}})


def test_reset_options_change_the_cell() -> None:
    env = PullEnv(time_limit_s=1.0, options={"force_noise_n": 0.0}, randomize=False)
    env.reset(seed=0, options={"tissue": {"length_m": 0.35}, "aponeurosis_stiffness_n_m": 80.0,
                               "fibre_direction": (0.0, 1.0, 0.0),
                               "material": "assets/materials/beef_default.toml"})
    scenario = env.episode.scenario
    assert scenario.tissue.length_m == 0.35 and scenario.aponeurosis.stiffness_n_m == 80.0
    assert scenario.sensors.force_noise_n == 0.0
    assert scenario.material.fibre_direction == (0.0, 1.0, 0.0)


def test_reset_options_keep_the_constructors() -> None:
    # A reset's material keeps the constructor's fibre direction; a reset's shape its other
    # shape fields.
    scenario = apply_options(Scenario(), {"fibre_direction": (0.0, 1.0, 0.0),
                                          "tissue": {"length_m": 0.35}},
                             {"material": "assets/materials/beef_default.toml",
                              "tissue": {"gap_m": 0.004}})
    assert scenario.material.fibre_direction == (0.0, 1.0, 0.0)
    assert (scenario.tissue.length_m, scenario.tissue.gap_m) == (0.35, 0.004)


def test_constructor_keeps_the_scenarios_resolution() -> None:
    scenario = Scenario(tissue=MuscleShape(cell_size_m=0.04))
    assert CutEnv(scenario=scenario).base.tissue.cell_size_m == 0.04
    assert CutEnv(scenario=scenario, cell_size_m=0.03).base.tissue.cell_size_m == 0.03
    assert CutEnv().base.tissue.cell_size_m == envs.COARSE_CELL_SIZE_M


def test_bad_option_values_are_refused_with_the_key() -> None:
    with pytest.raises(InputError, match=r"tissue\.length_m: expected a number"):
        apply_options(Scenario(), {"tissue": {"length_m": "long"}})
    with pytest.raises(InputError, match="aponeurosis_stiffness_n_m: must be > 0"):
        apply_options(Scenario(), {"aponeurosis_stiffness_n_m": -1.0})
    with pytest.raises(InputError, match="fibre_direction: expected 3 values"):
        apply_options(Scenario(), {"fibre_direction": [1.0, 0.0]})
    with pytest.raises(InputError, match=r"knife_pace: must be in \(0, 1\]"):
        apply_options(Scenario(), {"knife_pace": 1.5})


@pytest.mark.slow  # a whole episode
def test_a_pull_must_take_the_shank_clear() -> None:
    # Pull's knife cuts down to the table: the bindings it releases are not the task.
    _, truncated, still = _run(PullEnv(randomize=False), lambda _obs: np.zeros(3, np.float32))
    assert truncated and still["timed_out"] and not still["is_success"]
    assert still["released_fraction"] >= envs.PULL_TASK.separated_fraction


def test_divergence_ends_the_episode_with_a_finite_observation() -> None:
    env = CutEnv(time_limit_s=1.0)
    env.reset(seed=0)
    env.episode.sim.data.qvel[:] = np.nan  # the state a blow-up leaves behind
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert terminated and not truncated and info["diverged"]
    assert np.isfinite(obs).all() and np.isfinite(reward)


def test_an_unfinished_cut_is_truncated_at_the_time_limit_and_fails_the_cycle_time() -> None:
    still = np.zeros(4, np.float32)
    ends, rewards = {}, {}
    for fails, terminates in ((True, False), (True, True), (False, False)):
        env = CutEnv(time_limit_s=0.1, task={"cycle_time_fails": fails},
                     timeout_terminates=terminates)
        env.reset(seed=0)
        steps = [env.step(still) for _ in range(5)]  # 0.1 s of 20 ms control steps
        _, _, terminated, truncated, info = steps[-1]
        ends[fails, terminates] = (terminated, truncated, info["timed_out"],
                                   "timeout" in info["reward_terms"])
        rewards[fails, terminates] = [reward for _, reward, *_ in steps]
        assert not info["is_success"] and not info["success"]
    assert ends[True, False] == (False, True, True, True)  # the default
    assert ends[True, True] == (True, False, True, True)  # as before: the same reward
    assert rewards[True, True] == rewards[True, False]
    assert ends[False, False] == (False, True, False, False)


def test_gymnasium_bounds_an_episode_beyond_the_longest_default_time_limit() -> None:
    env = gym.make("musclecell/Pull-v2")
    assert env.spec.max_episode_steps == envs.registration.MAX_EPISODE_STEPS
    # The longest default limit: the slowest scripted knife on the longest, slowest-cut meat.
    bounds = dict((key, dist.bounds) for key, dist in env.unwrapped.randomization.entries)
    env.reset(seed=0, options={"randomize": False, "knife_pace": bounds["knife_pace"][0],
                               "cut_speed_m_s": bounds["cut_speed_m_s"][0],
                               "tissue": {"length_m": bounds["tissue.length_m"][1]}})
    inner = env.unwrapped
    assert inner._limit_s / inner._dt_s < envs.registration.MAX_EPISODE_STEPS


def test_a_time_limit_flag_that_is_not_a_flag_is_refused() -> None:
    with pytest.raises(InputError, match="timeout_terminates: expected true or false"):
        CutEnv(timeout_terminates="yes")


def _run(env: MuscleSeparationEnv, policy: str | Callable[[np.ndarray], np.ndarray]
         ) -> tuple[bool, bool, dict]:
    """One episode on the nominal coarse tissue, seed 0, the full default time limit."""
    obs, _ = env.reset(seed=0)
    env.action_space.seed(0)
    terminated = truncated = False
    while not (terminated or truncated):
        if policy == "scripted":
            action = env.scripted_action()
        elif policy == "random":
            action = env.action_space.sample()
        else:
            action = policy(obs)
        obs, _, terminated, truncated, info = env.step(action)
    return terminated, truncated, info


@pytest.mark.parametrize("env_class", SEPARATION_NOT_PULL)
def test_scripted_policy_separates_the_muscles(env_class: type[MuscleSeparationEnv]) -> None:
    terminated, _, info = _run(env_class(randomize=False), "scripted")
    assert terminated and info["success"] and not info["diverged"]
    assert info["torn_fraction"] <= envs.TaskParams().max_torn_fraction


@pytest.mark.slow  # a whole episode
def test_cut_needs_the_knife_down_to_the_lowest_bindings() -> None:
    # The plan's 15 mm above the table leaves the lowest bindings to the pull, which tears
    # them: too many for Cut-v1. A knife that skims the table cuts them.
    terminated, _, planned = _run(CutEnv(randomize=False), "scripted")
    assert terminated and not planned["success"]
    assert planned["torn_fraction"] > envs.CUT_TASK.max_torn_fraction
    terminated, _, skimming = _run(CutEnv(randomize=False), TableSkimmingKnife())
    assert terminated and skimming["success"] and not skimming["protective_stop"]
    assert skimming["torn_fraction"] < 0.5 * planned["torn_fraction"]


def test_a_knife_that_cuts_high_pays_for_the_depth_it_leaves() -> None:
    zero = np.zeros(3)
    def cost(tip_height_m: float, policy_cutting: bool) -> float:
        reading = Reading(zero, tip_height_m, np.eye(3), zero, zero, zero, zero, 0.5, 0.0,
                          0.0, 0.0, blade_contacts=1, under_blade=1, interface_offset_m=0.0)
        return -reward_terms(RewardParams(), reading, reading, 0.0, 0.01,
                             policy_cutting)["uncut_depth"]
    reach = RewardParams().cut_reach_m
    assert cost(0.015, True) == pytest.approx(RewardParams().uncut_depth_per_m
                                              * (0.015 - reach))
    assert cost(0.015, True) > cost(0.008, True) > cost(reach, True) == 0.0
    assert cost(0.015, False) == 0.0  # a scripted knife's depth is not the policy's


def test_a_knife_driven_into_the_table_stops_the_cell() -> None:
    terminated, _, info = _run(CutEnv(randomize=False), lambda _obs: np.array(
        [0.5, 0.0, 1.0, 0.0], np.float32))
    assert terminated and info["protective_stop"] and not info["success"]
    assert info["knife_force_peak_n"] > envs.CUT_TASK.knife_stop_force_n


@pytest.mark.slow
@pytest.mark.parametrize("env_class", [MuscleSeparationEnv, CutEnv])
def test_random_policy_does_not_separate(env_class: type[MuscleSeparationEnv]) -> None:
    _, _, info = _run(env_class(randomize=False), "random")
    assert not info["success"] and not info["diverged"]


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_make_vec_steps(mode: str) -> None:
    vec = gym.make_vec("musclecell/Cut-v1", num_envs=2, vectorization_mode=mode,
                       time_limit_s=0.5)
    obs, _ = vec.reset(seed=3)
    assert obs.shape == (2, vec.single_observation_space.shape[0])
    for _ in range(3):
        obs, rewards, _, _, _ = vec.step(vec.action_space.sample())
    assert np.isfinite(obs).all() and rewards.shape == (2,)
    vec.close()


def test_parameters_come_as_objects_or_json_mappings() -> None:
    env = CutEnv(reward={"success": 2.0}, task={"knife_stop_force_n": 50.0})
    assert env.reward_params.success == 2.0 and env.reward_params.progress == 10.0
    assert env.task.knife_stop_force_n == 50.0
    assert env.task.max_torn_fraction == envs.CUT_TASK.max_torn_fraction  # Cut-v1's own
    with pytest.raises(InputError, match=r"reward\.sucess"):
        CutEnv(reward={"sucess": 2.0})
