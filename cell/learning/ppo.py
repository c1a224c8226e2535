"""PPO training (Stable-Baselines3, ``MlpPolicy``) with checkpoints, a resume from the latest
one and a wall-clock limit.

A run's folder holds, at the end: the policy's files of :mod:`cell.learning.policyfile`
(``policy.npz`` and ``policy.json``: the network; ``normalization.json``: the observation and
reward statistics of ``VecNormalize``, which the policy's inputs need; ``optimizer.npz``:
Adam's state, for a resume; none of them pickled), ``learn.json`` (env, kwargs, seeds, steps,
wall time, hyper-parameters, the warm start),
``progress.csv`` (PPO's values per update), ``episodes.csv`` (one row per training episode),
``learning_curve.png`` and ``checkpoints/steps_NNNNNNNNN/`` (model, statistics, state). Each
env process collects its own part of every rollout (:mod:`cell.learning.segmentppo`). This
module imports Stable-Baselines3 and torch: the command line imports it when it trains.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import torch
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.logger import HumanOutputFormat, Logger
from stable_baselines3.common.vec_env import VecNormalize

from cell.errors import LearningError
from cell.io import read_json
from cell.learning.environments import WITHOUT_RAY, make_training_envs
from cell.learning.hyper import LearnSettings, PPOHyper, WarmStart, check_training_seeds
from cell.learning.logs import EpisodeLog, ProgressCsv
from cell.learning.policyfile import (
    PICKLED_FILES,
    WEIGHTS_FILE,
    check_policy_folder,
    read_normalization,
    restore_normalization,
    restore_training,
    save_policy,
)
from cell.learning.segmentppo import SegmentPPO
from cell.outputs import write_json
from cell.rayconnect import ray_session

STATE_FILE = "state.json"
LEARN_FILE = "learn.json"
CHECKPOINTS = "checkpoints"


@dataclass(frozen=True)
class LearnResult:
    """What a training invocation did: env ``steps`` of the run so far, its wall time over
    every invocation (s), and why this one stopped (``"steps"`` or ``"minutes"``)."""

    out: Path
    steps: int
    wall_s: float
    stopped_by: str


def save_checkpoint(directory: Path, model: PPO, normalize: VecNormalize,
                    state: dict[str, Any], state_file: str = STATE_FILE) -> None:
    """Write the policy's files (:func:`~cell.learning.policyfile.save_policy`) and
    ``state`` in ``directory``."""
    save_policy(directory, model, normalize, state["env_id"])
    write_json(directory / state_file, state)


def latest_checkpoint(out: Path) -> Path | None:
    """The checkpoint folder of ``out`` with the most steps (None when there is none)."""
    found = [(read_json(path, LearningError)["steps"], path.parent)
             for path in (out / CHECKPOINTS).glob(f"*/{STATE_FILE}")]
    return max(found)[1] if found else None


class _Progress(BaseCallback):
    """Logs each ended episode, checkpoints every ``settings.checkpoint_every`` steps (at the
    end of a rollout), tells the run's ``on_steps`` the env steps taken and stops training at
    the wall-clock deadline."""

    def __init__(self, run: _Run) -> None:
        super().__init__()
        self.run = run
        self.last_checkpoint = self.shown = run.steps_before

    def _on_step(self) -> bool:
        for done, info in zip(self.locals["dones"], self.locals["infos"], strict=True):
            if done:
                self.run.episodes.add(self.num_timesteps, info)
        if self.run.on_steps is not None:
            self.run.on_steps(self.num_timesteps - self.shown)
            self.shown = self.num_timesteps
        return time.monotonic() < self.run.deadline

    def _on_rollout_end(self) -> None:
        if self.num_timesteps - self.last_checkpoint >= self.run.settings.checkpoint_every:
            self.run.checkpoint(self.model)
            self.last_checkpoint = self.num_timesteps


class _Run:
    """One training invocation's folder, settings and clocks."""

    def __init__(self, out: Path, settings: LearnSettings, hyper: PPOHyper,
                 previous: dict[str, Any] | None) -> None:
        self.out, self.settings, self.hyper = out, settings, hyper
        #: Called with the env steps taken since its last call (progress), or None.
        self.on_steps: Callable[[int], object] | None = None
        self.first_seed = settings.seed if previous is None else previous["next_seed"]
        check_training_seeds(self.first_seed, settings.envs)
        self.steps_before = 0 if previous is None else previous["steps"]
        self.wall_before_s = 0.0 if previous is None else previous["wall_s"]
        self.started = time.monotonic()
        minutes = settings.minutes
        self.deadline = self.started + (float("inf") if minutes is None else 60.0 * minutes)
        self.episodes = EpisodeLog(out / "episodes.csv")
        self.normalize: VecNormalize | None = None
        # The warm start's settings and what it did; a resume keeps the anchor it set.
        self.warm_start: dict[str, Any] | None = None
        if previous is not None:
            self.warm_start = previous.get("warm_start")
        elif settings.warm_start is not None:
            self.warm_start = {"settings": asdict(settings.warm_start), "result": None}

    def state(self, model: PPO) -> dict[str, Any]:
        """The run's description and progress, as the checkpoints and learn.json hold it."""
        return {"env_id": self.settings.env_id, "env_kwargs": self.settings.env_kwargs,
                "seed": self.settings.seed, "envs": self.settings.envs,
                "steps": int(model.num_timesteps), "steps_target": self.settings.steps,
                "next_seed": self.first_seed + self.settings.envs,
                "wall_s": self.wall_before_s + time.monotonic() - self.started,
                "checkpoint_every": self.settings.checkpoint_every,
                "hyper": asdict(self.hyper), "warm_start": self.warm_start}

    def checkpoint(self, model: PPO) -> Path:
        """Save a checkpoint and rewrite the logs and the learning curve."""
        folder = self.out / CHECKPOINTS / f"steps_{model.num_timesteps:09d}"
        save_checkpoint(folder, model, self.normalize, self.state(model))
        self.episodes.write(self.out / "learning_curve.png")
        return folder


def learn(settings: LearnSettings, hyper: PPOHyper, out: Path,
          on_steps: Callable[[int], object] | None = None) -> LearnResult:
    """Train a new policy in ``out`` (which must hold no run yet); ``on_steps`` is called
    with the env steps taken as training goes (progress).

    Raises:
        LearningError: ``out`` already holds a run.
    """
    if latest_checkpoint(out) is not None or any(
            (out / name).exists() for name in (WEIGHTS_FILE, *PICKLED_FILES)):
        raise LearningError(out, None, "already holds a training run: --resume it or choose "
                            "another --out")
    run = _Run(out, settings, hyper, None)
    run.on_steps = on_steps
    return _train(run, None)


def resume(out: Path, env_id: str, steps: int, envs: int, minutes: float | None,
           checkpoint_every: int, on_steps: Callable[[int], object] | None = None,
           address: str | None = None) -> LearnResult:
    """Continue the run in ``out`` from its latest checkpoint up to ``steps`` env steps in
    all, with its own env kwargs, seed and hyper-parameters; ``envs`` new envs start at the
    training seeds after those already used (on the Ray cluster at ``address``, if any);
    ``on_steps`` as for :func:`learn`.

    Raises:
        LearningError: no checkpoint in ``out``, or ``env_id`` is not the run's env.
    """
    folder = latest_checkpoint(out)
    if folder is None:
        raise LearningError(out, None, "no checkpoint to resume")
    check_policy_folder(folder)  # an earlier release's pickled checkpoint is refused
    state = read_json(folder / STATE_FILE, LearningError)
    if state["env_id"] != env_id:
        raise LearningError(out, "ENV", f"the run trains {state['env_id']}, not {env_id}")
    settings = LearnSettings(env_id, state["env_kwargs"], state["seed"], envs, steps,
                             minutes, checkpoint_every, address=address)
    hyper = PPOHyper().with_overrides(state["hyper"])
    run = _Run(out, settings, hyper, state)
    run.on_steps = on_steps
    return _train(run, folder)


def _train(run: _Run, checkpoint: Path | None) -> LearnResult:
    """Build the envs and the model (new, or from ``checkpoint``), train, write the final
    files."""
    settings = run.settings
    # A 64x64 network gains nothing from torch's threads, which would take the cores the
    # envs' physics needs.
    torch.set_num_threads(1)
    with ExitStack() as session:
        ray = None if settings.address is None else session.enter_context(
            ray_session(settings.address, "--address", WITHOUT_RAY))
        venv = make_training_envs(settings.env_id, settings.env_kwargs, settings.envs, ray)
        session.callback(venv.close)
        if checkpoint is None:
            run.normalize = VecNormalize(venv, gamma=run.hyper.gamma)
            model = SegmentPPO("MlpPolicy", run.normalize, seed=run.first_seed, device="cpu",
                               **run.hyper.sb3_kwargs())
            if settings.warm_start is not None:
                from cell.learning.warmstart import warm_start

                run.warm_start["result"] = warm_start(model, run.normalize,
                                                      settings.warm_start, run.first_seed)
        else:
            # Rebuilt from numbers, never unpickled: the network and Adam's state from the
            # checkpoint, env i's first reset at first_seed + i.
            run.normalize = restore_normalization(venv, read_normalization(checkpoint))
            model = SegmentPPO("MlpPolicy", run.normalize, seed=run.first_seed, device="cpu",
                               **run.hyper.sb3_kwargs())
            restore_training(model, checkpoint)
        model.policy.log_std.requires_grad_(run.hyper.learn_log_std)
        model.set_logger(Logger(None, [HumanOutputFormat(sys.stdout),
                                       ProgressCsv(run.out / "progress.csv")]))
        remaining = settings.steps - model.num_timesteps
        if remaining > 0:
            model.learn(remaining, callback=_callbacks(run), reset_num_timesteps=False)
        run.checkpoint(model)
        state = run.state(model)
        stopped_by = "steps" if state["steps"] >= settings.steps else "minutes"
        save_checkpoint(run.out, model, run.normalize,
                        {**state, "stopped_by": stopped_by, "versions": _versions()},
                        state_file=LEARN_FILE)
    return LearnResult(run.out, state["steps"], state["wall_s"], stopped_by)


def _callbacks(run: _Run) -> CallbackList:
    """The run's progress and, after a warm start with an anchor, the anchor."""
    callbacks: list[BaseCallback] = [_Progress(run)]
    if run.warm_start is not None:
        from cell.learning.warmstart import DemonstratorAnchor

        warm = WarmStart(**run.warm_start["settings"])
        if warm.anchor_epochs:
            callbacks.append(DemonstratorAnchor(run.normalize, warm, run.first_seed))
    return CallbackList(callbacks)


def _versions() -> dict[str, str]:
    import stable_baselines3
    import torch

    return {"stable_baselines3": stable_baselines3.__version__, "torch": torch.__version__}
