"""The policies an evaluation compares: random actions, the best constant action, the
scripted plan (privileged: it reads the plan) and a learned PPO policy, each described by a
picklable :class:`PolicySpec` that a worker process turns into a callable."""

from __future__ import annotations

import pickle
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import gymnasium as gym
import numpy as np

from cell.errors import LearningError
from envs.policies import scripted_policy

#: The policies of an evaluation, in the table's order.
POLICIES = ("random", "best-constant", "scripted", "learned")
#: Levels of the constant grid along each action axis (the zero action is in it too).
CONSTANT_LEVELS = (0.25, 0.5, 1.0)
POLICY_FILE = "policy.zip"
NORMALIZE_FILE = "vecnormalize.pkl"

Policy = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class PolicySpec:
    """A policy to play: ``name`` is one of :data:`POLICIES` (``"constant"`` for a grid
    candidate too), ``action`` the constant action, ``folder`` the learned policy's files."""

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
    """The folder of a learned policy: ``path`` itself, or the folder of a ``policy.zip``;
    it must hold ``policy.zip`` and ``vecnormalize.pkl``.

    Raises:
        LearningError: naming the missing file.
    """
    path = Path(path)
    folder = path.parent if path.suffix == ".zip" else path
    for name in (POLICY_FILE, NORMALIZE_FILE):
        if not (folder / name).is_file():
            raise LearningError(folder / name, None, "not found (POLICY must be a learn "
                                "output folder, or a policy.zip with vecnormalize.pkl beside "
                                "it)")
    return folder


@lru_cache(maxsize=4)  # once per worker process, not once per episode
def load_learned(folder: str) -> Policy:
    """The deterministic actions of the PPO model in ``folder``, its observations normalised
    with the training's saved statistics (frozen, as in evaluation)."""
    from stable_baselines3 import PPO

    model = PPO.load(Path(folder) / POLICY_FILE, device="cpu")
    with (Path(folder) / NORMALIZE_FILE).open("rb") as file:
        normalize = pickle.load(file)
    normalize.training = False
    normalize.norm_reward = False
    return lambda obs: model.predict(normalize.normalize_obs(obs), deterministic=True)[0]


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
    if spec.name == "learned":
        return load_learned(spec.folder)
    raise LearningError(None, "policy", f"unknown policy {spec.name!r}; known: "
                        f"{', '.join(POLICIES)}")
