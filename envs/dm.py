"""The envs as ``dm_env.Environment`` s, for the DeepMind stack (Acme and the like).

Each task here is the Gymnasium env of :mod:`envs.separation` behind the ``dm_env`` API that
dm-control's environments implement (docs/design-notes.md says why not a dm-control task):
the same cell, observations, actions, rewards and episode ends, with specs. A step after the
last of an episode starts the next (``dm_env``'s contract); termination (success, failure,
protective stop, divergence) has discount 0, the time limit is a truncation with discount 1
(with ``timeout_terminates=True``, a termination with discount 0, as before this release).
The seed given at construction seeds the first reset; later episodes draw their worlds from
the env's own generator, as the Gymnasium env's unseeded resets do, so a seed fixes the
whole sequence. ``info`` holds the Gymnasium info of the last reset or step.

Needs the ``dm`` extra (``pip install 'musclecell[dm]'``).

Example:
    >>> from envs.dm import make
    >>> env = make("Cut-v2", seed=0, cell_size_m=0.05)
    >>> env.action_spec().shape, env.observation_spec().name
    ((4,), 'observation')
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from cell.errors import InputError
from cell.extras import optional
from envs.observation import OBSERVATION_BOUND
from envs.registration import DEPRECATED_IDS, ENV_IDS, env_creator
from envs.separation import MuscleSeparationEnv

dm_env = optional("dm_env", "dm", "envs.dm (the DeepMind environment API)")
specs = dm_env.specs
#: The Gymnasium ids' namespace, which the task names here leave out.
NAMESPACE = "musclecell"

#: The tasks: the Gymnasium ids of :data:`envs.registration.ENV_IDS` (each version, ``Steer``
#: among them) without the ``musclecell/`` namespace.
TASKS = tuple(env_id.removeprefix(f"{NAMESPACE}/") for env_id in ENV_IDS)


class SeparationEnvironment(dm_env.Environment):
    """A :class:`~envs.separation.MuscleSeparationEnv` (or a task of it) as a
    ``dm_env.Environment`` (module docstring).

    Args:
        env: the Gymnasium env to run.
        seed: seeds the first reset (None: fresh entropy).

    Example:
        >>> from envs.tasks import PullEnv
        >>> env = SeparationEnvironment(PullEnv(cell_size_m=0.05, time_limit_s=0.1), seed=1)
        >>> env.reset().first(), env.step(np.zeros(3, np.float32)).mid()
        (True, True)
    """

    def __init__(self, env: MuscleSeparationEnv, seed: int | None = None) -> None:
        self.gym_env = env
        self._seed = seed
        self._reset_next = True
        self.info: dict[str, Any] = {}

    def reset(self) -> dm_env.TimeStep:
        """Start an episode: a fresh world and cell, the plan's approach played."""
        observation, self.info = self.gym_env.reset(seed=self._seed)
        self._seed = None  # later worlds come from the env's generator
        self._reset_next = False
        return dm_env.restart(observation)

    def step(self, action: np.ndarray) -> dm_env.TimeStep:
        """One control step of ``action``; after the last step of an episode, a reset."""
        if self._reset_next:
            return self.reset()
        observation, reward, terminated, truncated, self.info = self.gym_env.step(action)
        if terminated:
            self._reset_next = True
            return dm_env.termination(reward, observation)
        if truncated:
            self._reset_next = True
            return dm_env.truncation(reward, observation)
        return dm_env.transition(reward, observation)

    def observation_spec(self) -> specs.BoundedArray:
        """The Gymnasium env's observation box: float32, named entries in the env's
        ``observation_names`` order."""
        return specs.BoundedArray(self.gym_env.observation_space.shape, np.float32,
                                  -OBSERVATION_BOUND, OBSERVATION_BOUND, name="observation")

    def action_spec(self) -> specs.BoundedArray:
        """The Gymnasium env's action box: float32 in [-1, 1], scaled by the env's limits."""
        space = self.gym_env.action_space
        return specs.BoundedArray(space.shape, np.float32, -1.0, 1.0, name="action")

    def close(self) -> None:
        """Free the Gymnasium env's renderer."""
        self.gym_env.close()


def make(name: str, /, seed: int | None = None, **kwargs: Any) -> SeparationEnvironment:
    """The ``dm_env`` environment of the task ``name`` (one of :data:`TASKS`, or a deprecated
    name of the previous release, which warns); ``kwargs`` go to the Gymnasium env as
    ``gymnasium.make``'s do (``task=`` among them).

    Raises:
        InputError: an unknown task.
    """
    old_id = f"{NAMESPACE}/{name}"
    if old_id in DEPRECATED_IDS:
        name = DEPRECATED_IDS[old_id].removeprefix(f"{NAMESPACE}/")
        warnings.warn(f"{old_id.removeprefix(f'{NAMESPACE}/')} is deprecated and goes in the "
                      f"next release: use {name}, the same task under its new version",
                      FutureWarning, stacklevel=2)
    if name not in TASKS:
        raise InputError(None, "task", f"unknown task {name!r}; known: {', '.join(TASKS)}")
    return SeparationEnvironment(env_creator(f"{NAMESPACE}/{name}")(**kwargs), seed=seed)
