"""The policies an evaluation compares: random actions, the best constant action, the
scripted plan (privileged: it reads the plan), the hand-written feedback policies of
:data:`envs.policies.DEMONSTRATORS` and a learned PPO policy, each described by a picklable
:class:`PolicySpec` that a worker process turns into a callable."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from cell.errors import LearningError
from cell.learning.hyper import CONSTANT_LEVELS
from cell.learning.policyfile import (
    PICKLED_FILES,
    POLICY_FILE,
    WEIGHTS_FILE,
    ObservationNormalizer,
    build_policy,
    check_policy_folder,
    observation_normalizer,
    read_normalization,
    read_policy,
)
from envs.policies import DEMONSTRATORS, scripted_policy

#: The baselines of every evaluation, in the table's order; the hand-written demonstrators
#: that fit the env follow them, then the learned policy.
BASELINES = ("random", "best-constant", "scripted")
LEARNED = "learned"

Policy = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class PolicySpec:
    """A policy to play: ``name`` is one of :data:`BASELINES` (``"constant"`` for a grid
    candidate too), a name of :data:`envs.policies.DEMONSTRATORS` or :data:`LEARNED`;
    ``action`` is the constant action, ``folder`` the learned policy's files."""

    name: str
    action: tuple[float, ...] = ()
    folder: str = ""


def constant_grid(dims: int, levels: tuple[float, ...] = CONSTANT_LEVELS
                  ) -> list[tuple[float, ...]]:
    """The constant actions the best constant is chosen from: zero, and each action axis alone
    at plus and minus each of ``levels`` (``1 + 2 * dims * len(levels)`` actions).

    Example:
        >>> constant_grid(2, levels=(1.0,))
        [(0.0, 0.0), (1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)]
    """
    grid = [(0.0,) * dims]
    for axis in range(dims):
        for level in levels:
            for sign in (1.0, -1.0):
                action = [0.0] * dims
                action[axis] = sign * level
                grid.append(tuple(action))
    return grid


def constant_pairs(best: tuple[float, ...], levels: tuple[float, ...] = CONSTANT_LEVELS
                   ) -> list[tuple[float, ...]]:
    """The second round of the constant search: ``best`` with each of its zero axes set to
    plus and minus each of ``levels`` (a task may need two axes at once, such as a knife's
    speed and its depth).

    Example:
        >>> constant_pairs((1.0, 0.0), levels=(0.5,))
        [(1.0, 0.5), (1.0, -0.5)]
    """
    pairs = []
    for axis, value in enumerate(best):
        if value != 0.0:
            continue
        for level in levels:
            for sign in (1.0, -1.0):
                action = list(best)
                action[axis] = sign * level
                pairs.append(tuple(action))
    return pairs


def policy_folder(path: str | Path) -> Path:
    """The folder of a learned policy: ``path`` itself, or the folder of a file in it
    (``policy.json``, ``policy.npz``, or an earlier release's ``policy.zip``); it must hold a
    policy in the format of :mod:`cell.learning.policyfile`.

    Raises:
        PickledPolicyError: the folder holds an earlier release's pickled policy only.
        LearningError: naming the file at fault.
    """
    path = Path(path)
    names = (WEIGHTS_FILE, POLICY_FILE, *PICKLED_FILES)
    if path.suffix in (".zip", ".npz", ".json", ".pkl") and path.name not in names:
        raise LearningError(path, None, f"a learned policy is a learn output folder (or "
                            f"a checkpoint's): give that folder or its {POLICY_FILE}")
    folder = path.parent if path.name in names else path
    check_policy_folder(folder)
    return folder


@dataclass(frozen=True)
class BasePolicy:
    """A demonstrator of :data:`envs.policies.DEMONSTRATORS` (``name``) whose action entries
    ``learned`` (indices) a network gives: a learned policy that learns only part of the
    action, such as the across offset of a knife whose depth a servo of the observation holds.

    Example:
        >>> base = BasePolicy("table-skimming-knife", (1,))
        >>> base.act(np.zeros(35, np.float32), np.array([0.0, 0.5, 0.0, 0.0]))[:2]
        array([1. , 0.5], dtype=float32)
    """

    name: str
    learned: tuple[int, ...]

    def act(self, obs: np.ndarray, network_action: np.ndarray) -> np.ndarray:
        """The demonstrator's action at ``obs``, the ``learned`` entries the network's."""
        action = np.array(DEMONSTRATORS[self.name]()(obs), np.float32)
        action[list(self.learned)] = np.asarray(network_action)[list(self.learned)]
        return action


@dataclass(frozen=True)
class LearnedPolicy:
    """A learned policy loaded from its files: deterministic actions of the network for
    observations normalised with the training's frozen statistics (on a ``base`` policy, the
    network's entries of its action); ``env_id`` is the env it was trained on."""

    network: Any
    normalize: ObservationNormalizer
    env_id: str
    base: BasePolicy | None = None

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        action = self.network.predict(self.normalize(obs), deterministic=True)[0]
        return action if self.base is None else self.base.act(obs, action)


@lru_cache(maxsize=4)  # once per worker process, not once per episode
def load_learned(folder: str) -> LearnedPolicy:
    """The learned policy saved in ``folder`` (see :mod:`cell.learning.policyfile`; nothing
    is unpickled).

    Raises:
        PickledPolicyError: an earlier release's pickled run.
        LearningError: a missing or broken file, named.
    """
    record, arrays = read_policy(Path(folder))
    base = record.get("base_policy")
    return LearnedPolicy(build_policy(record, arrays, Path(folder)),
                         observation_normalizer(read_normalization(Path(folder))),
                         record["env_id"],
                         None if base is None else BasePolicy(base["name"],
                                                              tuple(base["learned"])))


def make_policy(spec: PolicySpec, env: gym.Env, seed: int) -> Policy:
    """The callable of ``spec`` on ``env`` for the episode of ``seed`` (which seeds the
    random policy's own copy of the action space).

    Example:
        >>> env = gym.make("Pendulum-v1")
        >>> make_policy(PolicySpec("constant", (0.5,)), env, 0)(None)
        array([0.5], dtype=float32)
    """
    if spec.name == "random":
        space = gym.spaces.Box(env.action_space.low, env.action_space.high,
                               env.action_space.shape, env.action_space.dtype, seed=seed)
        return lambda _obs: space.sample()
    if spec.name in ("constant", "best-constant"):
        action = np.asarray(spec.action, dtype=np.float32)
        return lambda _obs: action
    if spec.name == "scripted":
        return scripted_policy(env)
    if spec.name in DEMONSTRATORS:
        return DEMONSTRATORS[spec.name]()
    if spec.name == LEARNED:
        return load_learned(spec.folder)
    raise LearningError(None, "policy", f"unknown policy {spec.name!r}; known: "
                        f"{', '.join([*BASELINES, *DEMONSTRATORS, LEARNED])}")
