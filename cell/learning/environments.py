"""The envs a run trains and evaluates on: Gymnasium ids, single envs, and the vectorised,
monitored and normalised envs of training."""

from __future__ import annotations

from functools import partial
from typing import TYPE_CHECKING, Any

import gymnasium as gym

import envs
from cell.errors import LearningError
from cell.learning.segments import SegmentWorker

if TYPE_CHECKING:
    from stable_baselines3.common.vec_env import VecEnv

#: Namespace of the project's envs: ``Cut-v2`` stands for ``musclecell/Cut-v2``.
NAMESPACE = "musclecell"
#: Start method of the training env processes: a fresh interpreter, not a fork of one that
#: has MuJoCo, numba's threads or torch's open.
START_METHOD = "forkserver"
#: What trains without Ray, for the error that says Ray is missing.
WITHOUT_RAY = "leave out --address: the envs run in processes on this machine"


def resolve_env_id(name: str) -> str:
    """The registered Gymnasium id that ``name`` names (a bare name gets the project's
    namespace).

    Example:
        >>> resolve_env_id("Cut-v2")
        'musclecell/Cut-v2'
    """
    envs.register_envs()
    for candidate in (name, f"{NAMESPACE}/{name}"):
        if candidate in gym.registry:
            return candidate
    ours = sorted(key for key in gym.registry if key.startswith(NAMESPACE + "/"))
    raise LearningError(None, "ENV", f"unknown env {name!r}; the project's: {', '.join(ours)}")


def make_env(env_id: str, env_kwargs: dict[str, Any]) -> gym.Env:
    """``gymnasium.make(env_id, **env_kwargs)``, a wrong keyword raised as
    :class:`LearningError`.

    Example:
        >>> make_env("musclecell/Cut-v2", {"time_limit_s": 0.4}).action_space.shape
        (4,)
    """
    envs.register_envs()  # in a fresh env process too
    try:
        return gym.make(env_id, **env_kwargs)
    except TypeError as exc:
        raise LearningError(None, "--env-kwargs", str(exc)) from None


def make_segment_worker(env_id: str, env_kwargs: dict[str, Any], index: int) -> SegmentWorker:
    """Training env ``index``, which plays its own rollout segments
    (:class:`~cell.learning.segments.SegmentWorker`)."""
    return SegmentWorker(make_env(env_id, env_kwargs), index)


def make_training_envs(env_id: str, env_kwargs: dict[str, Any], count: int,
                       ray: Any = None) -> VecEnv:
    """``count`` envs in a ``VecMonitor`` (episode returns and lengths), each a
    :func:`make_segment_worker`: one process each when more than one, or on ``ray`` (the
    module, joined to a cluster) one actor each (:class:`~cell.learning.rayenvs.RayVecEnv`);
    the caller seeds them and wraps them in ``VecNormalize``."""
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecMonitor

    make_env(env_id, env_kwargs).close()  # a bad keyword fails here, not in a child process
    if ray is not None:
        from cell.learning.rayenvs import RayVecEnv  # Ray's envs only where asked for

        return VecMonitor(RayVecEnv(ray, partial(make_segment_worker, env_id, env_kwargs),
                                    count))
    factories = [partial(make_segment_worker, env_id, env_kwargs, index)
                 for index in range(count)]
    if count == 1:
        return VecMonitor(DummyVecEnv(factories))
    return VecMonitor(SubprocVecEnv(factories, start_method=START_METHOD))
