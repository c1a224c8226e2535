"""The parameters of a training run: PPO's hyper-parameters and the run's settings, and the
seed ranges that keep training, tuning and evaluation apart."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from typing import Any

from cell.config import updated
from cell.errors import LearningError
from cell.rayconnect import check_address

#: First seed of the evaluation episodes; training seeds stay below it.
EVAL_SEED_START = 100_000
#: First seed of the episodes that tune the best constant action (never evaluated on).
TUNING_SEED_START = 200_000
#: Levels of the best constant's grid along each action axis (the zero action is in it too).
CONSTANT_LEVELS = (0.25, 0.5, 1.0)


@dataclass(frozen=True)
class PPOHyper:
    """PPO's hyper-parameters (Stable-Baselines3 names), for a low-dimensional continuous
    control task with episodes of a few hundred steps.

    Attributes:
        n_steps: env steps per env between two updates (a rollout holds ``n_steps`` times
            the number of envs); 1024 covers two to three episodes.
        batch_size: transitions per gradient step.
        n_epochs: passes over a rollout per update.
        learning_rate: Adam's step size (per unit gradient, no unit).
        gamma: discount per env step (20 ms): 0.995 looks about 200 steps, 4 s, ahead.
        gae_lambda: the advantage estimate's bias-variance trade-off.
        ent_coef: weight of the policy's entropy in the loss.
        clip_range: PPO's clipping of the probability ratio.
        max_grad_norm: gradient norm clipping.
        log_std_init: initial log standard deviation of the Gaussian actions (in action
            units of the [-1, 1] box).
        learn_log_std: whether PPO adapts that deviation (False keeps it: after a warm
            start, a clone precise to a fraction of a millimetre is moved off by the noisy
            policy's own optimum when the noise may grow).
        net_arch: hidden layer widths of the policy and value networks (separate, alike).

    Example:
        >>> PPOHyper().with_overrides({"n_steps": 64}).n_steps
        64
    """

    n_steps: int = 1024
    batch_size: int = 256
    n_epochs: int = 10
    learning_rate: float = 3e-4
    gamma: float = 0.995
    gae_lambda: float = 0.95
    ent_coef: float = 0.0
    clip_range: float = 0.2
    max_grad_norm: float = 0.5
    log_std_init: float = -0.5
    learn_log_std: bool = True
    net_arch: tuple[int, ...] = (64, 64)

    def __post_init__(self) -> None:
        for name in ("n_steps", "n_epochs"):
            if not getattr(self, name) >= 1:
                raise LearningError(None, f"hyper.{name}", f"must be >= 1, got "
                                    f"{getattr(self, name)}")
        if not self.batch_size >= 2:
            raise LearningError(None, "hyper.batch_size", f"must be >= 2, got {self.batch_size}")
        for name in ("learning_rate", "clip_range", "max_grad_norm"):
            if not getattr(self, name) > 0:
                raise LearningError(None, f"hyper.{name}", f"must be > 0, got "
                                    f"{getattr(self, name)}")
        for name in ("gamma", "gae_lambda"):
            if not 0 < getattr(self, name) <= 1:
                raise LearningError(None, f"hyper.{name}", f"must be in (0, 1], got "
                                    f"{getattr(self, name)}")
        if not isinstance(self.learn_log_std, bool):
            raise LearningError(None, "hyper.learn_log_std", f"must be true or false, got "
                                f"{self.learn_log_std!r}")
        if not self.ent_coef >= 0:
            raise LearningError(None, "hyper.ent_coef", f"must be >= 0, got {self.ent_coef}")
        if not self.net_arch or any(int(width) < 1 for width in self.net_arch):
            raise LearningError(None, "hyper.net_arch", f"must be positive widths, got "
                                f"{self.net_arch}")

    def with_overrides(self, overrides: dict[str, Any]) -> PPOHyper:
        """A copy with the fields of ``overrides`` replaced (a bad name or value raises
        :class:`LearningError`)."""
        # Types checked by the fields' annotations first, so that "many" steps is named as
        # hyper.n_steps, not met by a comparison in __post_init__.
        return updated(self, overrides, section="hyper", error=LearningError)

    def sb3_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of Stable-Baselines3's ``PPO``."""
        values = asdict(self)
        arch = list(values.pop("net_arch"))
        log_std_init = values.pop("log_std_init")
        values.pop("learn_log_std")  # applied to the built policy (:func:`ppo._train`)
        return {**values, "policy_kwargs": {"net_arch": {"pi": arch, "vf": arch},
                                            "log_std_init": log_std_init}}


@dataclass(frozen=True)
class WarmStart:
    """Behaviour cloning before PPO (see :mod:`cell.learning.warmstart`): ``episodes`` of the
    demonstrator ``demonstrator`` (a name of :data:`envs.policies.DEMONSTRATORS`) played in
    the training envs, each fit ``epochs`` passes of Adam (``learning_rate``, ``batch_size``)
    over the actor's squared action error plus ``value_weight`` times the critic's, then
    ``rounds`` of ``episodes`` played by the clone, labelled by the demonstrator and refitted
    with all before.

    Example:
        >>> WarmStart("table-skimming-knife").episodes
        24
    """

    demonstrator: str
    episodes: int = 24
    epochs: int = 100
    rounds: int = 2
    anchor_epochs: int = 0
    learning_rate: float = 1e-3
    batch_size: int = 256
    value_weight: float = 0.5

    def __post_init__(self) -> None:
        from envs.policies import DEMONSTRATORS

        if self.demonstrator not in DEMONSTRATORS:
            raise LearningError(None, "--warm-start", f"unknown demonstrator "
                                f"{self.demonstrator!r}; known: {', '.join(DEMONSTRATORS)}")
        for name in ("rounds", "anchor_epochs"):
            if not getattr(self, name) >= 0:
                raise LearningError(None, f"warm_start.{name}", f"must be >= 0, got "
                                    f"{getattr(self, name)}")
        for name in ("episodes", "epochs", "batch_size"):
            if not getattr(self, name) >= 1:
                raise LearningError(None, f"warm_start.{name}", f"must be >= 1, got "
                                    f"{getattr(self, name)}")
        for name in ("learning_rate", "value_weight"):
            if not getattr(self, name) > 0:
                raise LearningError(None, f"warm_start.{name}", f"must be > 0, got "
                                    f"{getattr(self, name)}")


@dataclass(frozen=True)
class LearnSettings:
    """What a training run trains on and for how long.

    Attributes:
        env_id: a registered Gymnasium id (``musclecell/Cut-v2``).
        env_kwargs: keyword arguments of ``gymnasium.make`` (JSON values).
        seed: env ``i`` of ``envs`` is reset with seed ``seed + i`` first, then draws its
            next worlds from its own generator; PPO's networks and sampling use ``seed`` too.
        envs: envs stepped side by side (one process each when more than one).
        steps: env steps of the whole run, those before a resume included.
        minutes: wall-clock budget of this invocation, min (None: no limit).
        checkpoint_every: env steps between checkpoints (at the end of a rollout).
        warm_start: behaviour cloning of a demonstrator before PPO (None: PPO from a random
            network); its env steps are not counted in ``steps``, its time is in
            ``minutes``.
        address: a Ray cluster whose workers play the envs, one actor each
            (:mod:`cell.learning.rayenvs`; ``auto``, ``HEAD_HOST:PORT`` or
            ``ray://HOST:PORT``); None: processes on this machine.

    Example:
        >>> LearnSettings("musclecell/Cut-v2", {}, seed=0, envs=2, steps=1000).seed
        0
    """

    env_id: str
    env_kwargs: dict[str, Any]
    seed: int
    envs: int
    steps: int
    minutes: float | None = None
    checkpoint_every: int = 50_000
    warm_start: WarmStart | None = None
    address: str | None = None

    def __post_init__(self) -> None:
        if self.address is not None:
            check_address(self.address, "--address")
        if not self.envs >= 1:
            raise LearningError(None, "--envs", f"must be >= 1, got {self.envs}")
        if not self.steps >= 1:
            raise LearningError(None, "--steps", f"must be >= 1, got {self.steps}")
        if self.minutes is not None and not self.minutes > 0:
            raise LearningError(None, "--minutes", f"must be > 0, got {self.minutes}")
        if not self.checkpoint_every >= 1:
            raise LearningError(None, "--checkpoint-every", f"must be >= 1, got "
                                f"{self.checkpoint_every}")
        check_training_seeds(self.seed, self.envs)


def check_training_seeds(first: int, count: int) -> None:
    """Raise :class:`LearningError` unless seeds ``first`` to ``first + count - 1`` are
    training seeds (>= 0 and below :data:`EVAL_SEED_START`)."""
    if first < 0 or first + count > EVAL_SEED_START:
        raise LearningError(None, "--seed", f"training seeds {first}..{first + count - 1} must "
                            f"lie in 0..{EVAL_SEED_START - 1} (the evaluation's seeds start at "
                            f"{EVAL_SEED_START})")


def parse_json_object(text: str | None, field: str) -> dict[str, Any]:
    """The JSON object of a command-line option (``{}`` for None).

    Example:
        >>> parse_json_object('{"time_limit_s": 0.4}', "--env-kwargs")
        {'time_limit_s': 0.4}
    """
    if text is None:
        return {}
    try:
        value = json.loads(text)
    except json.JSONDecodeError as exc:
        raise LearningError(None, field, f"not JSON: {exc}") from None
    if not isinstance(value, dict):
        raise LearningError(None, field, f"must be a JSON object, got {text!r}")
    return value
