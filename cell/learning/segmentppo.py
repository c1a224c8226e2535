"""The learner's side of rollouts collected by the env processes
(:mod:`cell.learning.segments`): PPO that sends every env process the actor and the frozen
observation statistics, gathers their segments and fills its rollout buffer from them.

The observation statistics are updated with the whole rollout at its end (when they still
train), and the rewards normalised as ``VecNormalize`` does, its running returns carried
through each env's steps, the return statistics updated with the whole rollout; values and
log-probabilities are computed in one batch with the learner's network, the callbacks then
see the rollout's steps in the order of Stable-Baselines3's lock-step loop.
"""

from __future__ import annotations

import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.buffers import RolloutBuffer
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecNormalize

from cell.learning.policyfile import (
    ObservationNormalizer,
    normalization_record,
    observation_normalizer,
)
from cell.learning.segments import Actor, Segment, SegmentRequest


def normalized_rewards(normalize: VecNormalize, rewards: np.ndarray, dones: np.ndarray
                       ) -> np.ndarray:
    """``rewards`` (steps, envs) as ``normalize`` scales them: its running discounted
    returns carried through the steps (zeroed after an episode's end), their statistics
    updated with the whole rollout when it trains, then each reward over the returns'
    deviation."""
    returns = np.empty(rewards.shape, np.float64)
    carry = normalize.returns
    for t in range(len(rewards)):
        carry = carry * normalize.gamma + rewards[t]
        returns[t] = carry
        carry = np.where(dones[t], 0.0, carry)
    normalize.returns = carry
    if normalize.training:
        normalize.ret_rms.update(returns.reshape(-1))
    return np.asarray(normalize.normalize_reward(rewards), np.float32)


def _stack(segments: list[Segment], name: str) -> np.ndarray:
    """One per-step field of every segment, (steps, envs, ...)."""
    return np.stack([getattr(segment, name) for segment in segments], axis=1)


class SegmentPPO(PPO):
    """Stable-Baselines3's PPO whose rollouts the env processes collect, each its whole
    segment (:class:`~cell.learning.segments.SegmentWorker`); its env must be a
    ``VecNormalize`` over such workers. Built and trained as ``PPO`` is.

    Example:
        >>> issubclass(SegmentPPO, PPO)
        True
    """

    def collect_rollouts(self, env: VecNormalize, callback: BaseCallback,
                         rollout_buffer: RolloutBuffer, n_rollout_steps: int) -> bool:
        """Fill ``rollout_buffer`` with ``n_rollout_steps`` steps of every env; False when a
        callback stops training."""
        self.policy.set_training_mode(False)
        rollout_buffer.reset()
        callback.on_rollout_start()  # the anchor holds the actor here, before it plays
        normalize = observation_normalizer(normalization_record(env))
        segments = env.env_method("collect", SegmentRequest(
            Actor.of(self.policy), normalize, n_rollout_steps, self.action_space.low,
            self.action_space.high, (int(self.seed or 0), int(self.num_timesteps))))
        raw, dones = _stack(segments, "observations"), _stack(segments, "dones")
        if env.training and env.norm_obs:
            env.obs_rms.update(raw.reshape(-1, raw.shape[-1]))
        rewards = normalized_rewards(env, _stack(segments, "rewards"), dones)
        for i, segment in enumerate(segments):  # a time limit's end: bootstrapped
            for t, obs in segment.truncated.items():
                rewards[t, i] += self.gamma * self._values(normalize, obs[None])[0]
        self._fill(rollout_buffer, normalize(raw).astype(np.float32),
                   _stack(segments, "actions"), rewards, dones)
        last = np.stack([segment.last_observation for segment in segments])
        rollout_buffer.compute_returns_and_advantage(
            last_values=torch.as_tensor(self._values(normalize, last)), dones=dones[-1])
        self._last_episode_starts = dones[-1]
        if not self._replay_steps(callback, segments, n_rollout_steps):
            return False
        callback.on_rollout_end()
        return True

    def _values(self, normalize: ObservationNormalizer, raw: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            values = self.policy.predict_values(
                torch.as_tensor(normalize(raw), dtype=torch.float32))
        return values.numpy().reshape(-1)

    def _fill(self, buffer: RolloutBuffer, observations: np.ndarray, actions: np.ndarray,
              rewards: np.ndarray, dones: np.ndarray) -> None:
        """The buffer's arrays, values and log-probabilities computed in one batch."""
        with torch.no_grad():
            values, log_probs, _ = self.policy.evaluate_actions(
                torch.as_tensor(observations.reshape(-1, observations.shape[-1])),
                torch.as_tensor(actions.reshape(-1, actions.shape[-1])))
        buffer.observations[:] = observations
        buffer.actions[:] = actions
        buffer.rewards[:] = rewards
        buffer.episode_starts[:] = np.vstack([self._last_episode_starts[None], dones[:-1]])
        buffer.values[:] = values.numpy().reshape(dones.shape)
        buffer.log_probs[:] = log_probs.numpy().reshape(dones.shape)
        buffer.pos, buffer.full = len(dones), True

    def _replay_steps(self, callback: BaseCallback, segments: list[Segment],
                      steps: int) -> bool:
        """The steps' callbacks and episode records, in the order of the lock-step loop;
        False when a callback stops training (after the whole rollout)."""
        keep_going = True
        for t in range(steps):
            dones = np.array([segment.dones[t] for segment in segments])
            infos = [segment.infos.get(t, {}) for segment in segments]
            self.num_timesteps += len(segments)
            callback.update_locals({"dones": dones, "infos": infos})
            keep_going = callback.on_step() and keep_going
            self._update_info_buffer(infos, dones)
        return keep_going
