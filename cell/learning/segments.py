"""Rollouts collected by the env processes themselves (this module: the env processes' side;
:mod:`cell.learning.segmentppo`: the learner's): each holds its env and a copy of the
policy's actor, and plays its whole segment of a rollout (its resets included) without
waiting for the other envs; the learner gathers the segments, updates the normalisation
statistics, computes values and log-probabilities in one batch and trains.

Why: in Stable-Baselines3's lock-step loop every env step of every env waits for the slowest
env, its pipe and the learner's policy call, and an env's reset (which builds the next world
and plays the approach) holds the other envs still; here the envs meet once per rollout.
What differs from Stable-Baselines3's own loop, and why it is still PPO: the observation
statistics are frozen while a rollout is collected and updated with the whole rollout at its
end (the policy acts on the statistics it was trained with; a rollout's statistics are in
the next one's), and the rewards are normalised with the return statistics after the
rollout. Each segment draws its action noise from a generator seeded by the run's seed, the
env's index and the run's step count, so that the same seed and the same number of envs give
the same run, whatever the processes' timing.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np

from cell.learning.policyfile import ObservationNormalizer

if TYPE_CHECKING:
    from stable_baselines3.common.policies import ActorCriticPolicy

#: The actor's activations in NumPy, by the name of their torch module.
_ACTIVATIONS = {"Tanh": np.tanh, "ReLU": lambda x: np.maximum(x, 0.0)}


@dataclass(frozen=True)
class Actor:
    """A policy network's Gaussian actor in NumPy: the mean action of a normalised
    observation through ``layers`` (weight, bias) with ``activation`` between them, and the
    noise's standard deviation ``exp(log_std)`` (action units).

    Example:
        >>> actor = Actor([(np.eye(2), np.zeros(2)), (np.ones((1, 2)), np.zeros(1))],
        ...               "Tanh", np.zeros(1))
        >>> actor.mean(np.zeros(2))
        array([0.])
    """

    layers: list[tuple[np.ndarray, np.ndarray]]
    activation: str
    log_std: np.ndarray

    @staticmethod
    def of(policy: ActorCriticPolicy) -> Actor:
        """The actor of a Stable-Baselines3 ``MlpPolicy`` (float32 copies)."""
        import torch

        modules = [*policy.mlp_extractor.policy_net, policy.action_net]
        layers = [(module.weight.detach().numpy().copy(), module.bias.detach().numpy().copy())
                  for module in modules if isinstance(module, torch.nn.Linear)]
        return Actor(layers, type(policy.activation_fn()).__name__,
                     policy.log_std.detach().numpy().copy())

    def mean(self, obs: np.ndarray) -> np.ndarray:
        """The mean action of the normalised observation ``obs``."""
        activation = _ACTIVATIONS[self.activation]
        hidden = np.asarray(obs, np.float32)
        for weight, bias in self.layers[:-1]:
            hidden = activation(weight @ hidden + bias)
        weight, bias = self.layers[-1]
        return weight @ hidden + bias


@dataclass(frozen=True)
class SegmentRequest:
    """What the learner sends every env process for one rollout: the actor, the frozen
    observation normalisation, the steps to play, the action bounds and the seed parts of the
    noise (the run's seed and its env steps so far; the process adds its env's index)."""

    actor: Actor
    normalize: ObservationNormalizer
    steps: int
    low: np.ndarray
    high: np.ndarray
    seed: tuple[int, int]


@dataclass
class Segment:
    """One env's part of a rollout: the raw observations the actions were taken at, the
    unclipped actions, the rewards and ends (``dones``) of each step, the final step's info
    of each ended episode (with ``episode``: its return ``r`` and length ``l``) by step,
    the observation after a time-limit truncation by step (for its value) and the
    observation the next segment starts from."""

    observations: np.ndarray
    actions: np.ndarray
    rewards: np.ndarray
    dones: np.ndarray
    infos: dict[int, dict[str, Any]] = field(default_factory=dict)
    truncated: dict[int, np.ndarray] = field(default_factory=dict)
    last_observation: np.ndarray | None = None


class SegmentWorker(gym.Wrapper):
    """An env that plays rollout segments for the learner in its own process
    (:meth:`collect`, called through the vector env's ``env_method``), and otherwise passes
    resets and steps through, keeping the observation it is at.

    Example:
        >>> from cell.learning.environments import make_env
        >>> worker = SegmentWorker(make_env("musclecell/Cut-v2", {"time_limit_s": 0.2}), 0)
        >>> worker.reset(seed=0)[0].shape == worker.observation_space.shape
        True
    """

    def __init__(self, env: gym.Env, index: int) -> None:
        super().__init__(env)
        self.index = index
        self._obs: np.ndarray | None = None
        self._episode = (0.0, 0)

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        """The env's reset; the observation is kept."""
        obs, info = self.env.reset(**kwargs)
        self._obs, self._episode = obs, (0.0, 0)
        return obs, info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """The env's step; the observation, the episode's return and length are kept."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._obs = obs
        self._episode = (self._episode[0] + float(reward), self._episode[1] + 1)
        return obs, reward, terminated, truncated, info

    def collect(self, request: SegmentRequest) -> Segment:
        """Play ``request.steps`` steps of the Gaussian actor, resetting at each episode's
        end."""
        rng = np.random.default_rng([*request.seed, self.index])
        std = np.exp(request.actor.log_std)
        shape = (request.steps, *np.shape(self._obs))
        segment = Segment(np.empty(shape, np.float32),
                          np.empty((request.steps, len(std)), np.float32),
                          np.empty(request.steps, np.float32), np.zeros(request.steps, bool))
        for t in range(request.steps):
            obs = self._obs
            action = request.actor.mean(request.normalize(obs)) + std * rng.standard_normal(
                len(std))
            _, reward, terminated, truncated, info = self.step(
                np.clip(action, request.low, request.high).astype(np.float32))
            segment.observations[t], segment.actions[t], segment.rewards[t] = obs, action, reward
            if terminated or truncated:
                segment.dones[t] = True
                segment.infos[t] = {**info, "episode": {"r": self._episode[0],
                                                        "l": self._episode[1]}}
                if truncated and not terminated:
                    segment.truncated[t] = np.array(self._obs, np.float32)
                self.reset()
        segment.last_observation = np.array(self._obs, np.float32)
        return segment

