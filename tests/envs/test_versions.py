"""Each env version's fingerprint, pinned: a change of what an env means cannot land under the
same id.

The fingerprint of an id is its observation's names, its action space, its parameters (action
limits, reward weights, task), the cut and pull it plans, its constructor's options, where its
knife's cutting force comes from, its default randomisation, and the rewards of a seeded
rollout under a fixed action sequence on the coarse cell (a fingerprint pinned before a part
existed is compared on the parts it has). The pinned values are in
``tests/envs/env_fingerprints.json``.

If this test fails, the env's behaviour changed: register the changed env under a new version
(``envs/registration.py``, the card's version history) and pin the new id with
``python tests/envs/test_versions.py``, which adds the fingerprint of every registered id not
pinned yet; a pinned one is never rewritten (a version means one thing for good).
"""

from __future__ import annotations

import json
import sys
from dataclasses import asdict
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import envs
from cell.errors import InputError, RandomizationError
from envs.randomization import load_randomization
from tests.marks import slow_but

PINNED = Path(__file__).with_name("env_fingerprints.json")
ROLLOUT_SEED = 7
ACTION_SEED = 123
ROLLOUT_STEPS = 12
#: Rewards may differ by float rounding across machines, never by more.
REWARD_TOLERANCE = 1e-6
BUMP = ("changed: give the changed env a new version in envs/registration.py (and its card's "
        "version history), then pin it with `python tests/envs/test_versions.py`")


def fingerprint(env_id: str) -> dict[str, Any]:
    """What ``env_id`` means, as JSON-ready data (module docstring)."""
    env = gym.make(env_id, cell_size_m=envs.COARSE_CELL_SIZE_M)
    inner = env.unwrapped
    space = env.action_space
    meaning = {
        "observation_names": list(inner.observation_names),
        "action_space": {"shape": list(space.shape), "low": space.low.tolist(),
                         "high": space.high.tolist()},
        "limits": asdict(inner.limits),
        "reward": asdict(inner.reward_params),
        "task": asdict(inner.task),
        "cut": asdict(inner.base.cut),
        "pull": asdict(inner.base.pull),
        "options": inner.options,
        "knife_force": inner.base.aponeurosis.knife_force,
        "randomization": [[key, asdict(distribution)]
                          for key, distribution in inner.randomization.entries],
    }
    env.reset(seed=ROLLOUT_SEED)
    actions = np.random.default_rng(ACTION_SEED).uniform(-1.0, 1.0, (ROLLOUT_STEPS,
                                                                      *space.shape))
    rewards = []
    for action in actions.astype(np.float32):
        _, reward, terminated, truncated, _ = env.step(action)
        rewards.append(float(reward))
        if terminated or truncated:
            break
    env.close()
    # Through JSON, so that tuples compare as the pinned lists do.
    return json.loads(json.dumps({**meaning, "rollout_rewards": rewards}))


@pytest.mark.parametrize("env_id", sorted(envs.ENV_IDS))
def test_the_env_version_means_what_it_meant(env_id: str) -> None:
    pinned = json.loads(PINNED.read_text())
    assert env_id in pinned, f"{env_id} has no pinned fingerprint: pin it (module docstring)"
    now, then = fingerprint(env_id), pinned[env_id]
    rewards, pinned_rewards = now.pop("rollout_rewards"), then.pop("rollout_rewards")
    for part in then:
        assert now[part] == then[part], f"{env_id}: its {part} {BUMP}"
    assert len(rewards) == len(pinned_rewards), f"{env_id}: its rollout's length {BUMP}"
    assert np.allclose(rewards, pinned_rewards, rtol=0.0, atol=REWARD_TOLERANCE), (
        f"{env_id}: its seeded rollout's rewards {BUMP}")


# One old id in the default run, every one with ``-m slow``: each makes two envs.
@pytest.mark.parametrize("old_id", slow_but(sorted(envs.DEPRECATED_IDS)[:1],
                                             sorted(envs.DEPRECATED_IDS)))
def test_an_old_id_warns_and_makes_its_new_env(old_id: str) -> None:
    with pytest.warns(FutureWarning, match=f"use {envs.DEPRECATED_IDS[old_id]}"):
        old = gym.make(old_id, time_limit_s=0.2)
    new = gym.make(envs.DEPRECATED_IDS[old_id], time_limit_s=0.2)
    assert type(old.unwrapped) is type(new.unwrapped)
    assert old.unwrapped.task == new.unwrapped.task


@pytest.mark.parametrize(("old", "new", "value"), [
    ("binding_stiffness_n_m", "aponeurosis_stiffness_n_m", 42.0),
    ("camera_noise_at_1m_m", "perception_noise_sigma_at_1m_m", 0.002),
    ("shape", "tissue", {"length_m": 0.4}),
])
def test_an_old_option_name_warns_and_builds_the_same_world(old: str, new: str,
                                                             value: object) -> None:
    assert envs.RENAMED_OPTIONS[old] == new
    with pytest.warns(FutureWarning, match=f"{old} is renamed: use {new}"):
        renamed = envs.CutEnv(time_limit_s=0.2, randomize=False, options={old: value})
    plain = envs.CutEnv(time_limit_s=0.2, randomize=False, options={new: value})
    with pytest.warns(FutureWarning, match=f"{old} is renamed"):
        old_reset, info = plain.reset(seed=3, options={old: value})
    assert renamed.reset(seed=3)[0].tolist() == old_reset.tolist()
    assert renamed.episode.scenario == plain.episode.scenario
    assert info["world"] == {new: value}
    with pytest.raises(InputError, match=f"{old}: given beside its new name {new}"):
        envs.apply_options(plain.base, {old: value, new: value})


def test_an_old_option_name_in_a_randomization_file_warns(tmp_path: Path) -> None:
    table = 'kind = "uniform"\nlow = 40.0\nhigh = 60.0\n'
    old = tmp_path / "old.toml"
    old.write_text("[shape.length_m]\nkind = \"uniform\"\nlow = 0.4\nhigh = 0.5\n"
                   f"[binding_stiffness_n_m]\n{table}")
    with pytest.warns(FutureWarning, match="old.toml: the env option shape is renamed"):
        randomization = load_randomization(old)
    assert randomization.keys == ("tissue.length_m", "aponeurosis_stiffness_n_m")
    both = tmp_path / "both.toml"
    both.write_text(f"[binding_stiffness_n_m]\n{table}[aponeurosis_stiffness_n_m]\n{table}")
    with pytest.raises(RandomizationError, match="binding_stiffness_n_m: given beside"):
        load_randomization(both)


if __name__ == "__main__":
    old = json.loads(PINNED.read_text()) if PINNED.exists() else {}
    fresh = {env_id: fingerprint(env_id) for env_id in sorted(envs.ENV_IDS) if env_id not in old}
    PINNED.write_text(json.dumps({**old, **fresh}, indent=1, sort_keys=True) + "\n")
    sys.stdout.write(f"pinned {', '.join(fresh) or 'nothing new'} in {PINNED}\n")
