"""Gymnasium envs of the muscle separation cell, registered on import under ``musclecell/``;
the four current ones (:data:`envs.registration.CURRENT_IDS`):

- ``musclecell/MuscleSeparation-v2``: the policy drives the knife and the pull
  (:class:`envs.separation.MuscleSeparationEnv`),
- ``musclecell/Cut-v2``: the knife only, the pull follows the scripted plan
  (:class:`envs.tasks.CutEnv`),
- ``musclecell/Pull-v2``: the pull only, the knife follows the scripted plan, down to the
  table, at a pace of its own (:class:`envs.tasks.PullEnv`),
- ``musclecell/Steer-v2``: the knife on a path planned from a wrong perception
  (:class:`envs.steer.SteerEnv`).

Each class's docstring is its manual. Keyword arguments of ``gymnasium.make`` go to the
class. The older versions stay registered for runs and policies made on them
(:mod:`envs.registration`, each manual's version history).

Example:
    >>> import gymnasium, envs
    >>> env = gymnasium.make("musclecell/Cut-v2", cell_size_m=0.05)
"""

from envs.observation import OBSERVATION_NAMES
from envs.options import OPTION_KEYS, RENAMED_OPTIONS, apply_options
from envs.params import ActionLimits, RewardParams, TaskParams
from envs.randomization import Randomization, draw, load_randomization
from envs.registration import CURRENT_IDS, DEPRECATED_IDS, ENV_IDS, register_envs
from envs.separation import MuscleSeparationEnv
from envs.settings import COARSE_CELL_SIZE_M, CUT_TASK, PULL_TASK, task_scenario
from envs.steer import SteerEnv
from envs.tasks import CutEnv, PullEnv

register_envs()

__all__ = [
    "COARSE_CELL_SIZE_M",
    "CURRENT_IDS",
    "CUT_TASK",
    "DEPRECATED_IDS",
    "ENV_IDS",
    "OBSERVATION_NAMES",
    "OPTION_KEYS",
    "PULL_TASK",
    "RENAMED_OPTIONS",
    "ActionLimits",
    "CutEnv",
    "MuscleSeparationEnv",
    "PullEnv",
    "Randomization",
    "RewardParams",
    "SteerEnv",
    "TaskParams",
    "apply_options",
    "draw",
    "load_randomization",
    "register_envs",
    "task_scenario",
]
