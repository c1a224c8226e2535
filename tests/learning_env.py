"""A test env for the learning tests: Cut-v0 with the outcome keys of the final info that
``musclecell evaluate`` reads, registered on import as ``musclecelltest/Cut-v0`` (a learning
test names it ``tests.learning_env:musclecelltest/Cut-v0`` so that env processes import it)."""

from typing import Any

import gymnasium as gym
import numpy as np

from envs import CutEnv

ENV_ID = "tests.learning_env:musclecelltest/Cut-v0"
#: Short, coarse episodes: 10 control steps on a short muscle pair.
ENV_KWARGS = {"time_limit_s": 0.2, "cell_size_m": 0.08, "options": {"shape": {"length_m": 0.3}}}


class OutcomeKeys(gym.Wrapper):
    """Adds ``success``, ``knife_force_peak_n``, ``flesh_damage_s``, ``elapsed_s`` and
    ``protective_stop`` to each step's info."""

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        inner = self.env.unwrapped
        info.update(success=inner.separated, knife_force_peak_n=1.0, flesh_damage_s=0.0,
                    elapsed_s=inner.elapsed_s, protective_stop=False)
        return obs, reward, terminated, truncated, info


def _make(**kwargs: Any) -> gym.Env:
    return OutcomeKeys(CutEnv(**kwargs))


if "musclecelltest/Cut-v0" not in gym.registry:
    gym.register("musclecelltest/Cut-v0", entry_point=_make)
