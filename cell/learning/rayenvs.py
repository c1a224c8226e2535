"""Training envs on Ray (``musclecell learn --address``): each env a Ray actor of one CPU,
spread over the cluster's nodes, the learner in the process that trains; a vector env that
Stable-Baselines3 uses as it uses ``SubprocVecEnv``.

Each actor holds a :func:`~cell.learning.environments.make_segment_worker` (the factory it
is given), as an env process does, and plays its own segment of every rollout
(:mod:`cell.learning.segments`): the actors play side by side and meet the learner once per
rollout. Env ``i`` is seeded as the local env ``i`` is, so the same seed and the same number
of envs train the same policy here and on a cluster.

A lost actor (its worker process or its node died) is replaced: a new actor, reset at a
training seed drawn from its env's first seed and the number of replacements, takes its
place. The episode it was playing is dropped: its steps already in a rollout stay there
(bootstrapped at the rollout's end, as every segment's last step is) and it never ends in
``episodes.csv``; a segment the actor was collecting is played again by its replacement from
the reset, and a step it was taking returns as the end of a truncated episode.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import VecEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvStepReturn

from cell.errors import LearningError, PoolError
from cell.learning.hyper import EVAL_SEED_START

#: How long a new actor may take to start and reset before the cluster counts as unable to
#: host it (no CPU free, its node gone), s.
START_TIMEOUT_S = 300.0
#: Losses of one env in a row (its replacement lost before it answers) that end the run.
MAX_LOSSES_IN_A_ROW = 3


class EnvHost:
    """One training env in a Ray worker: the commands of Stable-Baselines3's env processes
    as methods (a step that ends an episode resets and keeps the final observation in the
    info, as ``SubprocVecEnv``'s worker does).

    Example:
        >>> from functools import partial
        >>> from cell.learning.environments import make_segment_worker
        >>> make = partial(make_segment_worker, "musclecell/Cut-v2", {"time_limit_s": 0.2})
        >>> host = EnvHost(make, 0)
        >>> host.reset(0, None)[0].shape == host.spaces()[0].shape
        True
    """

    def __init__(self, make: Callable[[int], gym.Env], index: int) -> None:
        self.env = make(index)

    def spaces(self) -> tuple[gym.Space, gym.Space]:
        """The env's observation and action spaces."""
        return self.env.observation_space, self.env.action_space

    def reset(self, seed: int | None, options: dict[str, Any] | None
              ) -> tuple[Any, dict[str, Any]]:
        """The env's reset at ``seed`` (None: its own generator's next world)."""
        return self.env.reset(seed=seed, **({"options": options} if options else {}))

    def step(self, action: np.ndarray) -> tuple[Any, float, bool, dict[str, Any], dict]:
        """A step in Stable-Baselines3's convention: observation, reward, done, info and the
        reset's info (the next episode's first observation after an end)."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        info["TimeLimit.truncated"] = truncated and not terminated
        reset_info: dict[str, Any] = {}
        if terminated or truncated:
            info["terminal_observation"] = obs
            obs, reset_info = self.env.reset()
        return obs, float(reward), terminated or truncated, info, reset_info

    def call(self, name: str, args: tuple, kwargs: dict[str, Any]) -> Any:
        """The env's method ``name`` (through its wrappers) called."""
        return self.env.get_wrapper_attr(name)(*args, **kwargs)

    def get(self, name: str) -> Any:
        """The env's attribute ``name`` (through its wrappers)."""
        return self.env.get_wrapper_attr(name)

    def set(self, name: str, value: Any) -> None:
        """Set the attribute ``name`` of the outer wrapper."""
        setattr(self.env, name, value)

    def is_wrapped(self, wrapper: type[gym.Wrapper]) -> bool:
        """Whether ``wrapper`` is among the env's wrappers."""
        from stable_baselines3.common.env_util import is_wrapped

        return is_wrapped(self.env, wrapper)


class RayVecEnv(VecEnv):
    """``count`` envs, env ``i`` made by ``make(i)``, as Ray actors of one CPU each, spread
    over the nodes of the Ray this process has joined; ``replacements`` counts the actors
    replaced after a loss (module docstring).

    Example (on a joined Ray, :func:`cell.rayconnect.ray_session`)::

        make = partial(make_segment_worker, "musclecell/Cut-v2", {"time_limit_s": 1.0})
        venv = RayVecEnv(ray, make, 2)
        venv.seed(0)
        observations = venv.reset()  # (2, observation size)

    Raises:
        LearningError: on ``--envs``, when the cluster has fewer CPUs than envs.
    """

    def __init__(self, ray: Any, make: Callable[[int], gym.Env], count: int) -> None:
        cpus = int(ray.cluster_resources().get("CPU", 0))
        if count > cpus:
            raise LearningError(None, "--envs", f"{count} envs need a CPU each; the Ray "
                                f"cluster has {cpus}")
        self._ray = ray
        self._host = ray.remote(num_cpus=1, max_restarts=0)(EnvHost).options(
            scheduling_strategy="SPREAD")
        self._start = lambda index: self._host.remote(make, index)
        self._actors = [self._start(index) for index in range(count)]
        self._first_seeds: list[int | None] = [None] * count
        self._actions: np.ndarray | None = None
        self._last_obs: list[Any] = [None] * count
        self.replacements = 0
        observation_space, action_space = self._wait(self._actors[0].spaces.remote())
        super().__init__(count, observation_space, action_space)

    def _wait(self, ref: Any) -> Any:
        try:
            return self._ray.get(ref, timeout=START_TIMEOUT_S)
        except self._ray.exceptions.GetTimeoutError:
            raise PoolError(None, "--address", f"a training env did not start within "
                            f"{START_TIMEOUT_S:g} s: the cluster has no CPU free") from None

    def _replace(self, index: int) -> Any:
        """A new actor for env ``index``, reset at a training seed of its own; its first
        observation."""
        self._ray.kill(self._actors[index], no_restart=True)
        self.replacements += 1
        self._actors[index] = self._start(index)
        seed = int(np.random.default_rng(
            [self._first_seeds[index] or 0, index, self.replacements]).integers(EVAL_SEED_START))
        return self._wait(self._actors[index].reset.remote(seed, None))[0]

    def _gather(self, indices: Sequence[int], method: str, arguments: Sequence[tuple],
                lost: Callable[[int, Any], Any] | None = None) -> list[Any]:
        """``method`` of the actors of ``indices`` with their ``arguments``, called side by
        side; a lost actor is replaced, then ``lost(index, first observation)`` is its
        result (None: the call again, on the replacement)."""
        refs = [getattr(self._actors[i], method).remote(*args)
                for i, args in zip(indices, arguments, strict=True)]
        return [self._result(i, method, args, ref, lost)
                for i, args, ref in zip(indices, arguments, refs, strict=True)]

    def _result(self, index: int, method: str, args: tuple, ref: Any,
                lost: Callable[[int, Any], Any] | None) -> Any:
        for _ in range(MAX_LOSSES_IN_A_ROW):
            try:
                return self._ray.get(ref)
            except self._ray.exceptions.RayActorError:
                first = self._replace(index)
                if lost is not None:
                    return lost(index, first)
                ref = getattr(self._actors[index], method).remote(*args)
        raise PoolError(None, "--address", f"training env {index} lost its Ray worker "
                        f"{MAX_LOSSES_IN_A_ROW} times in a row")

    def reset(self) -> np.ndarray:
        """Every env reset (at its seed after :meth:`seed`)."""
        for i, seed in enumerate(self._seeds):
            if self._first_seeds[i] is None:
                self._first_seeds[i] = seed
        results = self._gather(range(self.num_envs), "reset",
                               list(zip(self._seeds, self._options, strict=True)))
        self._reset_seeds()
        self._reset_options()
        self._last_obs = [obs for obs, _ in results]
        self.reset_infos = [info for _, info in results]
        return np.stack(self._last_obs)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        """The envs' steps; a lost env's step is the end of a truncated episode."""
        results = self._gather(range(self.num_envs), "step",
                               [(action,) for action in self._actions], self._truncated)
        obs, rewards, dones, infos, self.reset_infos = zip(*results, strict=True)
        self._last_obs = list(obs)
        return np.stack(obs), np.array(rewards), np.array(dones), list(infos)

    def _truncated(self, index: int, first: Any) -> tuple[Any, float, bool, dict[str, Any],
                                                          dict]:
        info = {"TimeLimit.truncated": True, "terminal_observation": self._last_obs[index]}
        return first, 0.0, True, info, {}

    def close(self) -> None:
        for actor in self._actors:
            self._ray.kill(actor, no_restart=True)

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        chosen = self._get_indices(indices)
        return self._gather(chosen, "get", [(attr_name,)] * len(chosen))

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        chosen = self._get_indices(indices)
        self._gather(chosen, "set", [(attr_name, value)] * len(chosen))

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None,
                   **method_kwargs: Any) -> list[Any]:
        chosen = self._get_indices(indices)
        return self._gather(chosen, "call", [(method_name, method_args, method_kwargs)]
                            * len(chosen))

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper],
                       indices: VecEnvIndices = None) -> list[bool]:
        chosen = self._get_indices(indices)
        return self._gather(chosen, "is_wrapped", [(wrapper_class,)] * len(chosen))
