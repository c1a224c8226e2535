"""A warm start for PPO: behaviour cloning of a hand-written feedback policy before PPO trains,
and an anchor that keeps PPO near it.

PPO from a random network explores a knife's depth by noise and plateaus short of a servo that
a line of arithmetic writes (:class:`envs.policies.TableSkimmingKnife`; the measured rates are
on the docs' learning and benchmarks pages); starting from what a cell engineer would write and
letting PPO improve on it is how demonstrations serve robot learning. The demonstrator reads
only the observation, so the network can represent it; its episodes run in the training envs
(their seeds, their observation statistics) and count in the run's wall clock. The actor's mean
is fitted to the demonstrator's actions, then to the demonstrator's actions at the states the
clone itself reaches (DAgger: a plain clone of the knife, off by a fraction of a millimetre,
drives it into the table), and the critic to the episodes' discounted, normalised returns, so
that PPO's first updates start from a value estimate rather than from noise. The observation
and reward statistics stay those of the demonstrations from then on: the clone's inputs keep
their meaning.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.vec_env import VecNormalize

from cell.learning.hyper import WarmStart
from envs.policies import DEMONSTRATORS


@dataclass(frozen=True)
class Demonstrations:
    """Whole episodes with the demonstrator's action at every observation: raw observations,
    those actions and the discounted returns of the normalised rewards (one row per env
    step), and the episodes' count and successes."""

    observations: np.ndarray
    actions: np.ndarray
    returns: np.ndarray
    episodes: int
    successes: int

    @staticmethod
    def merge(parts: list[Demonstrations]) -> Demonstrations:
        """All of ``parts`` as one set."""
        return Demonstrations(
            np.concatenate([p.observations for p in parts]),
            np.concatenate([p.actions for p in parts]),
            np.concatenate([p.returns for p in parts]),
            sum(p.episodes for p in parts), sum(p.successes for p in parts))


Actor = Callable[[np.ndarray], np.ndarray]
"""Actions (envs, action) for raw observations (envs, observation)."""


def play(normalize: VecNormalize, warm: WarmStart, gamma: float, actor: Actor | None
         ) -> Demonstrations:
    """Play ``actor`` (the demonstrator itself when None) in ``normalize``'s envs until
    ``warm.episodes`` episodes have ended, labelling every observation with the demonstrator's
    action (the statistics of ``normalize`` follow, as in training); episodes cut off at the
    end are dropped."""
    demonstrator = DEMONSTRATORS[warm.demonstrator]()
    count = normalize.num_envs
    running: list[list[tuple[np.ndarray, np.ndarray, float]]] = [[] for _ in range(count)]
    finished: list[list[tuple[np.ndarray, np.ndarray, float]]] = []
    succeeded: list[bool] = []
    normalize.reset()
    while len(finished) < warm.episodes:
        observations = normalize.get_original_obs()
        labels = np.stack([demonstrator(obs) for obs in observations])
        _, _, dones, infos = normalize.step(labels if actor is None else actor(observations))
        rewards = normalize.get_original_reward()
        for i in range(count):
            running[i].append((observations[i], labels[i], float(rewards[i])))
            if dones[i]:
                finished.append(running[i])
                succeeded.append(bool(infos[i].get("is_success", False)))
                running[i] = []
    finished = finished[:warm.episodes]
    returns = [_discounted(normalize.normalize_reward(np.array([r for *_, r in episode])),
                           gamma) for episode in finished]
    return Demonstrations(
        observations=np.array([obs for episode in finished for obs, _, _ in episode]),
        actions=np.array([action for episode in finished for _, action, _ in episode]),
        returns=np.concatenate(returns), episodes=len(finished),
        successes=sum(succeeded[:warm.episodes]))


def _discounted(rewards: np.ndarray, gamma: float) -> np.ndarray:
    returns = np.empty_like(rewards, dtype=float)
    following = 0.0
    for i in range(len(rewards) - 1, -1, -1):
        following = rewards[i] + gamma * following
        returns[i] = following
    return returns


def fit_actor(policy: ActorCriticPolicy, optimizer: torch.optim.Optimizer,
              generator: torch.Generator, batch_size: int, epochs: int, inputs: torch.Tensor,
              actions: torch.Tensor, returns: torch.Tensor | None = None,
              value_weight: float = 0.5) -> dict[str, float | None]:
    """``epochs`` passes of ``optimizer`` over shuffled batches of ``batch_size`` of the
    squared error of the action mean to ``actions`` plus, given ``returns``, ``value_weight``
    times the value's; returns the last pass's mean losses."""
    for _ in range(epochs):
        action_losses, value_losses = [], []
        for batch in torch.randperm(len(actions), generator=generator).split(batch_size):
            mean = policy.get_distribution(inputs[batch]).distribution.mean
            loss = action_loss = torch.mean((mean - actions[batch]) ** 2)
            if returns is not None:
                value = policy.predict_values(inputs[batch]).squeeze(-1)
                value_loss = torch.mean((value - returns[batch]) ** 2)
                loss = action_loss + value_weight * value_loss
                value_losses.append(value_loss.item())
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            action_losses.append(action_loss.item())
    return {"action_mse": float(np.mean(action_losses)),
            "value_mse": float(np.mean(value_losses)) if value_losses else None}


def clone(model: PPO, normalize: VecNormalize, demonstrations: Demonstrations,
          warm: WarmStart, seed: int) -> dict[str, float]:
    """Fit ``model``'s action mean to the demonstrated actions and its value to their
    returns (mean squared errors, Adam); returns the last epoch's mean losses."""
    inputs = torch.as_tensor(normalize.normalize_obs(demonstrations.observations),
                             dtype=torch.float32)
    optimizer = torch.optim.Adam(model.policy.parameters(), lr=warm.learning_rate)
    return fit_actor(model.policy, optimizer, torch.Generator().manual_seed(seed),
                     warm.batch_size, warm.epochs, inputs,
                     torch.as_tensor(demonstrations.actions, dtype=torch.float32),
                     torch.as_tensor(demonstrations.returns, dtype=torch.float32),
                     warm.value_weight)


def warm_start(model: PPO, normalize: VecNormalize, warm: WarmStart, seed: int
               ) -> dict[str, float | int | str]:
    """Clone the demonstrator's episodes, then for ``warm.rounds`` rounds play the clone,
    label what it saw with the demonstrator's actions and refit on everything (DAgger: the
    clone meets the states its own small errors lead to, which the demonstrator never
    visits). Returns the record a run keeps: the demonstrator, env steps played, the
    demonstrator's and the last clone's success fractions, the last fit's losses."""
    parts = [play(normalize, warm, model.gamma, None)]
    losses = clone(model, normalize, parts[0], warm, seed)

    def actor(observations: np.ndarray) -> np.ndarray:
        return model.predict(normalize.normalize_obs(observations), deterministic=True)[0]

    for round_index in range(warm.rounds):
        parts.append(play(normalize, warm, model.gamma, actor))
        losses = clone(model, normalize, Demonstrations.merge(parts), warm,
                       seed + round_index + 1)
    # The clone is precise to a fraction of a millimetre in inputs normalised by these
    # statistics; statistics drifting under PPO would move it off the demonstrator. (The
    # reward's scale, which the critic was fitted in, stays with them.)
    normalize.training = False
    return {"demonstrator": warm.demonstrator, "rounds": warm.rounds,
            "env_steps": sum(len(part.actions) for part in parts),
            "demonstrator_success": parts[0].successes / parts[0].episodes,
            "clone_success": parts[-1].successes / parts[-1].episodes, **losses}


class DemonstratorAnchor(BaseCallback):
    """Holds PPO's actor near the demonstrator: after each PPO update (and so before a
    checkpoint or the end), ``warm.anchor_epochs`` passes of Adam over the cloning loss on the
    update's rollout, each observation labelled with the demonstrator's action (none when 0).

    Why: from the clone, PPO's updates drift the knife's mean actions (slower, higher, aside)
    and lose the clone's successes, though the demonstrator's actions have the better
    deterministic return; the anchor lets PPO change the actions only as far as its
    advantage outweighs the cloning loss.
    """

    def __init__(self, normalize: VecNormalize, warm: WarmStart, seed: int) -> None:
        super().__init__()
        self.normalize, self.warm = normalize, warm
        self.demonstrator = DEMONSTRATORS[warm.demonstrator]()
        self.generator = torch.Generator().manual_seed(seed)
        self.optimizer: torch.optim.Optimizer | None = None
        self.pending: tuple[torch.Tensor, torch.Tensor] | None = None

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        # The buffer is emptied before the next rollout: keep its observations for after the
        # update that uses them.
        buffer = self.model.rollout_buffer
        inputs = buffer.observations.reshape(-1, buffer.observations.shape[-1])
        labels = np.stack([self.demonstrator(obs)
                           for obs in self.normalize.unnormalize_obs(inputs)])
        self.pending = (torch.as_tensor(inputs, dtype=torch.float32),
                        torch.as_tensor(labels, dtype=torch.float32))

    def _on_rollout_start(self) -> None:
        self._hold()

    def _on_training_end(self) -> None:
        self._hold()

    def _hold(self) -> None:
        if self.pending is None or self.warm.anchor_epochs == 0:
            return
        inputs, labels = self.pending
        self.pending = None
        policy = self.model.policy
        if self.optimizer is None:
            self.optimizer = torch.optim.Adam(policy.parameters(), lr=self.warm.learning_rate)
        fit_actor(policy, self.optimizer, self.generator, self.warm.batch_size,
                  self.warm.anchor_epochs, inputs, labels)
