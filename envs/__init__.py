"""Gymnasium envs of the muscle separation cell, registered on import under ``musclecell/``:

- ``musclecell/MuscleSeparation-v0``: the policy drives the knife and the pull,
- ``musclecell/Cut-v0``: the knife only (the pull follows the scripted plan),
- ``musclecell/Pull-v0``: the pull only (the knife follows the scripted plan, down to the
  table, at a pace of its own).

Keyword arguments of ``gymnasium.make`` go to :class:`MuscleSeparationEnv`.

Example:
    >>> import gymnasium, envs
    >>> env = gymnasium.make("musclecell/Cut-v0", cell_size_m=0.05)
"""

from gymnasium.envs.registration import register, registry

from envs.observation import OBSERVATION_NAMES
from envs.options import OPTION_KEYS, apply_options
from envs.params import ActionLimits, RewardParams, TaskParams
from envs.randomization import Randomization, draw, load_randomization
from envs.separation import (
    COARSE_CELL_SIZE_M,
    CUT_TASK,
    PULL_TASK,
    CutEnv,
    MuscleSeparationEnv,
    PullEnv,
)

_ENTRY_POINTS = {
    "musclecell/MuscleSeparation-v0": "envs.separation:MuscleSeparationEnv",
    "musclecell/Cut-v0": "envs.separation:CutEnv",
    "musclecell/Pull-v0": "envs.separation:PullEnv",
}


def register_envs() -> None:
    """Register the three envs with Gymnasium (once; importing :mod:`envs` does it)."""
    for env_id, entry_point in _ENTRY_POINTS.items():
        if env_id not in registry:
            register(id=env_id, entry_point=entry_point, disable_env_checker=False)


register_envs()

__all__ = [
    "COARSE_CELL_SIZE_M",
    "CUT_TASK",
    "OBSERVATION_NAMES",
    "OPTION_KEYS",
    "PULL_TASK",
    "ActionLimits",
    "CutEnv",
    "MuscleSeparationEnv",
    "PullEnv",
    "Randomization",
    "RewardParams",
    "TaskParams",
    "apply_options",
    "draw",
    "load_randomization",
    "register_envs",
]
