"""Training and evaluating policies on the envs: PPO (Stable-Baselines3) with its checkpoints,
logs and learning curve, the policy's files (numbers and JSON, never a pickle), and the
evaluation of a learned policy against the random, the best constant, the scripted policy and
the hand-written demonstrators on the same seeds, with confidence intervals and the paired
comparison with the best demonstrator.

It owns what ``musclecell learn`` and ``musclecell evaluate`` run. torch and
Stable-Baselines3 (the ``learn`` extra) are imported inside the functions that need them, so
that importing this package costs neither.

Seed ranges: a training run's envs start from seeds below :data:`EVAL_SEED_START`, the
evaluation uses seeds from :data:`EVAL_SEED_START` up and the best constant action is tuned on
seeds from :data:`TUNING_SEED_START` up, so no evaluation world was seen in training or tuning.
"""

from cell.learning.hyper import EVAL_SEED_START, TUNING_SEED_START, LearnSettings, PPOHyper

__all__ = ["EVAL_SEED_START", "TUNING_SEED_START", "LearnSettings", "PPOHyper"]
