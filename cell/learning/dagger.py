"""Learning from a privileged expert: DAgger (Ross, Gordon and Bagnell 2011) on the learner's
own observation.

Why: on ``Steer-v2`` the expert that steers on the true interface
(:func:`envs.policies.true_interface_policy`, the task's ceiling) knows what no observation
shows, and PPO held near a hand-written rule adds nothing measurable (the docs' learning
page). The learner sees only its observation (the knife's force and torque, its progress,
the perceived path and the offsets it commanded a step before, which are its memory), and is
fitted to the expert's action at the states it reaches itself: the expert plays the first
round, then in each round the latest network plays ``episodes`` worlds, every observation is
labelled with the expert's action at that state, and the network's action mean is refitted
on every round so far (squared error, Adam). A plain clone of the expert's own episodes only
learns to hold the offset it already commands, since there the command is always the truth;
the learner's own episodes show it the states where the command is off and what the knife
then feels.

A run's folder holds the policy's files (:func:`cell.learning.policyfile.save_network`, read
by ``musclecell evaluate`` like a PPO run's), the learning curve ``learning_curve.csv`` (per
round: who played, env steps so far, wall time, the episodes' tip-to-interface distance,
success, torn fraction, return, the fit's error), ``learning_curve.png`` when matplotlib is
there, and ``dagger.json`` (settings, curve, why it stopped). Training seeds: round ``r``
plays seeds ``seed + r * episodes`` on, all below the evaluation's.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np

from cell.errors import LearningError
from cell.learning.baselines import BasePolicy
from cell.learning.environments import make_env
from cell.learning.hyper import check_training_seeds
from cell.learning.policyfile import WEIGHTS_FILE, ObservationNormalizer, save_network
from cell.learning.segments import Actor
from cell.outputs import figure_png, write_atomic, write_json, write_rows
from cell.rayconnect import check_address
from envs.policies import DEMONSTRATORS, true_interface_policy

if TYPE_CHECKING:
    import torch
    from stable_baselines3.common.policies import ActorCriticPolicy

Policy = Callable[[np.ndarray], np.ndarray]
#: The privileged experts by name: each builds the policy from the env whose truth it reads.
EXPERTS: dict[str, Callable[[gym.Env], Policy]] = {"true-interface": true_interface_policy}
CURVE_FILE = "learning_curve.csv"
CURVE_COLUMNS = ("round", "played_by", "episodes", "env_steps", "wall_s", "tip_mean_mm",
                 "tip_scored", "success_rate", "torn_fraction", "mean_return", "action_mse")
RUN_FILE = "dagger.json"
#: The subfolder of a run that holds its averaged network (``average_rounds``).
AVERAGE_FOLDER = "average"
#: The least variance an observation entry is scaled by (its units squared): an entry that
#: hardly moves in the expert's episodes would otherwise turn the learner's small departures
#: into inputs at the clip.
MIN_VARIANCE = 1e-4
#: A round's fit in stages of equal numbers of batches at these fractions of the learning
#: rate: the labels' across part is noisy (the observation does not determine where the
#: interface is), and the weights' jitter at the full rate moves the knife's depth, which the
#: observation does determine, by a fraction of a millimetre (the table is 2 mm below the tip).
FIT_STAGES = (1.0, 0.25, 0.0625)
#: The normalised observation's clip, as ``VecNormalize``'s.
CLIP_OBS = 10.0


@dataclass(frozen=True)
class DaggerSettings:
    """A DAgger run (module docstring): ``rounds`` rounds of ``episodes`` episodes each (the
    first the expert's), after each ``fit_batches`` steps of Adam (``learning_rate``, then
    :data:`FIT_STAGES` of it) on batches of ``batch_size`` drawn from every round so far (a
    fit's cost stays the same as the data grows); the network's hidden widths ``net_arch``;
    ``workers`` processes play the episodes; no round starts that would, at the last round's
    pace, end after ``minutes`` (None: no limit). ``average_rounds`` > 0 also saves, in the
    subfolder :data:`AVERAGE_FOLDER`, an exponential average of the networks that end each
    round over about that many rounds (decay ``1 - 1/average_rounds``; the learner plays its
    latest network): each round's fit ends at a low learning rate (:data:`FIT_STAGES`), and
    averaging such ends (stochastic weight averaging, Izmailov et al. 2018) smooths out the
    rounds' jitter. ``init``, a policy folder of ``env_id``
    (:mod:`cell.learning.policyfile`), starts the run from that network and its observation
    statistics: then the learner plays every round, the first too. ``base``, a demonstrator's
    name, makes the learned policy that demonstrator but for the action's ``learned``
    entries, which the network gives (:class:`~cell.learning.baselines.BasePolicy`).
    ``address``, a Ray cluster's (``auto``, ``HEAD_HOST:PORT``, ``ray://HOST:PORT``), plays
    the episodes there as Ray tasks instead of ``workers`` processes, the fits here; the
    same seed gives the same run.

    Example:
        >>> DaggerSettings(rounds=2, episodes=4).seeds(1)
        range(4, 8)
    """

    env_id: str = "musclecell/Steer-v2"
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    expert: str = "true-interface"
    seed: int = 0
    rounds: int = 8
    episodes: int = 16
    fit_batches: int = 1000
    learning_rate: float = 1e-3
    batch_size: int = 256
    net_arch: tuple[int, ...] = (64, 64)
    workers: int = 2
    minutes: float | None = None
    init: str = ""
    base: str = ""
    learned: tuple[int, ...] = ()
    average_rounds: int = 0
    address: str | None = None

    def __post_init__(self) -> None:
        if self.address is not None:
            check_address(self.address, "address")
        if self.expert not in EXPERTS:
            raise LearningError(None, "expert", f"unknown expert {self.expert!r}; known: "
                                f"{', '.join(EXPERTS)}")
        for name in ("rounds", "episodes", "fit_batches", "batch_size", "workers"):
            if not getattr(self, name) >= 1:
                raise LearningError(None, name, f"must be >= 1, got {getattr(self, name)}")
        if not self.fit_batches >= len(FIT_STAGES):
            raise LearningError(None, "fit_batches", f"must be >= {len(FIT_STAGES)} (one per "
                                f"stage of the learning rate), got {self.fit_batches}")
        if not self.average_rounds >= 0:
            raise LearningError(None, "average_rounds", f"must be >= 0, got "
                                f"{self.average_rounds}")
        if not self.learning_rate > 0:
            raise LearningError(None, "learning_rate", f"must be > 0, got {self.learning_rate}")
        if self.minutes is not None and not self.minutes > 0:
            raise LearningError(None, "minutes", f"must be > 0, got {self.minutes}")
        if not self.net_arch or any(int(width) < 1 for width in self.net_arch):
            raise LearningError(None, "net_arch", f"must be positive widths, got "
                                f"{self.net_arch}")
        if self.base and (self.base not in DEMONSTRATORS or not self.learned):
            raise LearningError(None, "base", f"a base policy needs a demonstrator's name "
                                f"({', '.join(DEMONSTRATORS)}) and learned action entries, got "
                                f"{self.base!r} and {self.learned}")
        check_training_seeds(self.seed, self.rounds * self.episodes)

    @property
    def base_policy(self) -> BasePolicy | None:
        """The policy the network's entries go into (None: the network's whole action)."""
        return BasePolicy(self.base, tuple(self.learned)) if self.base else None

    def seeds(self, round_index: int) -> range:
        """The training seeds of round ``round_index``."""
        first = self.seed + round_index * self.episodes
        return range(first, first + self.episodes)


@dataclass(frozen=True)
class DaggerEpisode:
    """One episode to play: the env (id and JSON of its keyword arguments), the expert that
    labels it, the seed, and the learner that acts (its actor and observation
    normalisation, and the policy its entries go into; no actor: the expert acts)."""

    env_id: str
    env_kwargs_json: str
    expert: str
    seed: int
    actor: Actor | None = None
    normalize: ObservationNormalizer | None = None
    base: BasePolicy | None = None


@lru_cache(maxsize=2)  # one env per worker process, reset for each of its episodes
def _env(env_id: str, env_kwargs_json: str) -> gym.Env:
    return make_env(env_id, json.loads(env_kwargs_json))


def play_episode(task: DaggerEpisode) -> dict[str, Any]:
    """Play one episode of ``task``: every observation with the expert's action there, and
    the outcome (return, success, torn fraction, the tip's mean distance to the true
    interface in mm, None when the tip never came across from it)."""
    env = _env(task.env_id, task.env_kwargs_json)
    expert = EXPERTS[task.expert](env)
    low, high = env.action_space.low, env.action_space.high
    obs, info = env.reset(seed=task.seed)
    observations, labels, total, done = [], [], 0.0, False
    while not done:
        label = expert(obs)
        action = label if task.actor is None else np.clip(
            task.actor.mean(task.normalize(obs)), low, high).astype(np.float32)
        if task.actor is not None and task.base is not None:
            action = task.base.act(obs, action)
        observations.append(obs)
        labels.append(label)
        obs, reward, terminated, truncated, info = env.step(action)
        total += float(reward)
        done = terminated or truncated
    tip = info.get("tip_distance_mean_m")
    return {"seed": task.seed, "observations": np.array(observations, np.float32),
            "labels": np.array(labels, np.float32), "return": total,
            "success": bool(info["is_success"]), "torn_fraction": float(info["torn_fraction"]),
            "tip_mean_mm": None if tip is None else 1e3 * float(tip)}


def normalizer_of(observations: np.ndarray) -> ObservationNormalizer:
    """The frozen normalisation of ``observations`` (rows): their mean and variance, the
    variance no less than :data:`MIN_VARIANCE`."""
    return ObservationNormalizer(observations.mean(axis=0),
                                 np.maximum(observations.var(axis=0), MIN_VARIANCE), CLIP_OBS,
                                 1e-8)


def normalization_json(normalize: ObservationNormalizer, count: int) -> dict[str, Any]:
    """``normalize`` as :func:`cell.learning.policyfile.read_normalization` reads it (no
    reward statistics: nothing here learns from rewards)."""
    return {"obs_rms": {"mean": normalize.mean.tolist(), "var": normalize.var.tolist(),
                        "count": float(count)},
            "ret_rms": {"mean": 0.0, "var": 1.0, "count": 1.0}, "clip_obs": normalize.clip,
            "clip_reward": CLIP_OBS, "epsilon": normalize.epsilon, "gamma": 0.99,
            "norm_obs": True, "norm_reward": False, "training": False}


def _network(settings: DaggerSettings, env: gym.Env) -> ActorCriticPolicy:
    """A fresh Gaussian MLP policy of ``env``'s spaces, seeded by the run's seed."""
    import torch
    from stable_baselines3.common.policies import ActorCriticPolicy

    torch.manual_seed(settings.seed)
    arch = [int(width) for width in settings.net_arch]
    return ActorCriticPolicy(env.observation_space, env.action_space,
                             lambda _progress: settings.learning_rate,
                             net_arch={"pi": arch, "vf": arch})


def _start(settings: DaggerSettings, env: gym.Env
           ) -> tuple[ActorCriticPolicy, ObservationNormalizer | None]:
    """The network a run starts from and its observation statistics: ``settings.init``'s,
    or a fresh network and none yet."""
    from cell.learning import policyfile

    if not settings.init:
        return _network(settings, env), None
    folder = Path(settings.init)
    record, arrays = policyfile.read_policy(folder)
    if record["env_id"] != settings.env_id:
        raise LearningError(folder, "env_id", f"the policy is of {record['env_id']}, the run "
                            f"trains {settings.env_id}")
    policy = policyfile.build_policy(record, arrays, folder)
    policy.set_training_mode(True)
    return policy, policyfile.observation_normalizer(policyfile.read_normalization(folder))


def curve_row(round_index: int, played_by: str, episodes: list[dict[str, Any]],
              env_steps: int, wall_s: float, action_mse: float) -> dict[str, Any]:
    """The learning curve's row of one round (``episodes`` as :func:`play_episode` returns
    them; the tip's distance over the episodes that scored it, None when none did)."""
    tips = [e["tip_mean_mm"] for e in episodes if e["tip_mean_mm"] is not None]
    return {"round": round_index, "played_by": played_by,
            "episodes": len(episodes), "env_steps": env_steps, "wall_s": round(wall_s, 1),
            "tip_mean_mm": float(np.mean(tips)) if tips else None, "tip_scored": len(tips),
            "success_rate": float(np.mean([e["success"] for e in episodes])),
            "torn_fraction": float(np.mean([e["torn_fraction"] for e in episodes])),
            "mean_return": float(np.mean([e["return"] for e in episodes])),
            "action_mse": action_mse}


def train(settings: DaggerSettings, out: Path,
          report: Callable[[dict[str, Any]], None] | None = None) -> dict[str, Any]:
    """Run DAgger (module docstring) into the folder ``out``, rewriting the policy and the
    curve after every round; ``report`` gets each curve row. Returns ``dagger.json``'s
    record.

    Raises:
        LearningError: ``out`` already holds a policy, or bad settings.
    """
    import torch

    from cell.learning.evaluate import episode_runner
    from cell.learning.warmstart import fit_actor

    if (out / WEIGHTS_FILE).exists():
        raise LearningError(out, None, "already holds a policy: choose another --out")
    torch.set_num_threads(1)  # the envs' physics needs the cores more than a 64x64 network
    started = time.monotonic()
    env = make_env(settings.env_id, dict(settings.env_kwargs))
    policy, normalize = _start(settings, env)
    env.close()
    optimizer = torch.optim.Adam(policy.parameters(), lr=settings.learning_rate)
    averaged = _averaged(policy, settings.average_rounds)
    generator = torch.Generator().manual_seed(settings.seed)
    rng = np.random.default_rng(settings.seed)
    kwargs_json = json.dumps(settings.env_kwargs, sort_keys=True)
    observations: list[np.ndarray] = []
    labels: list[np.ndarray] = []
    curve: list[dict[str, Any]] = []
    stopped_by = "rounds"
    with episode_runner(settings.workers, play_episode, address=settings.address) as play:
        for round_index in range(settings.rounds):
            round_started = time.monotonic()
            actor = None if normalize is None else Actor.of(policy)
            tasks = [DaggerEpisode(settings.env_id, kwargs_json, settings.expert, seed, actor,
                                   normalize, settings.base_policy)
                     for seed in settings.seeds(round_index)]
            episodes = play(tasks)
            observations += [episode["observations"] for episode in episodes]
            labels += [episode["labels"] for episode in episodes]
            seen = np.concatenate(observations)
            normalize = normalize or normalizer_of(seen)
            inputs, targets = normalize(seen), np.concatenate(labels)
            for fraction in FIT_STAGES:
                for group in optimizer.param_groups:
                    group["lr"] = settings.learning_rate * fraction
                drawn = rng.integers(len(seen), size=settings.fit_batches // len(FIT_STAGES)
                                     * settings.batch_size)
                losses = fit_actor(policy, optimizer, generator, settings.batch_size, 1,
                                   torch.as_tensor(inputs[drawn], dtype=torch.float32),
                                   torch.as_tensor(targets[drawn]))
            if averaged is not None:
                averaged.update_parameters(policy)
            curve.append(curve_row(round_index, "expert" if actor is None else "learner",
                                   episodes, len(seen),
                                   time.monotonic() - started, losses["action_mse"]))
            if report is not None:
                report(curve[-1])
            saved = [(out, policy)] + ([] if averaged is None else
                                       [(out / AVERAGE_FOLDER, averaged.module)])
            for folder, network in saved:
                save_network(folder, network, normalization_json(normalize, len(seen)),
                             settings.env_id, "DAgger", len(seen), round_index + 1,
                             None if not settings.base else {"name": settings.base,
                                                             "learned": list(settings.learned)})
            write_rows(out / CURVE_FILE, CURVE_COLUMNS, curve)
            pace_s = time.monotonic() - round_started
            if (settings.minutes is not None and round_index + 1 < settings.rounds
                    and time.monotonic() - started + pace_s > 60.0 * settings.minutes):
                stopped_by = "minutes"
                break
    record = {"settings": asdict(settings), "curve": curve, "stopped_by": stopped_by,
              "wall_s": time.monotonic() - started}
    write_json(out / RUN_FILE, record)
    _write_figure(out / "learning_curve.png", curve)
    return record


def _averaged(policy: ActorCriticPolicy, rounds: int) -> torch.optim.swa_utils.AveragedModel | None:
    """The exponential average of ``policy``'s weights over about ``rounds`` rounds (None
    for 0)."""
    if rounds == 0:
        return None
    from torch.optim.swa_utils import AveragedModel, get_ema_multi_avg_fn

    return AveragedModel(policy, multi_avg_fn=get_ema_multi_avg_fn(1.0 - 1.0 / rounds),
                         use_buffers=True)


def _write_figure(path: Path, curve: list[dict[str, Any]]) -> None:
    """The curve's tip distance and success rate against env steps (nothing without
    matplotlib, an optional extra)."""
    try:
        import matplotlib
    except ImportError:
        return
    matplotlib.use("Agg")  # files only, no display
    import matplotlib.pyplot as plt

    steps = [row["env_steps"] for row in curve]
    figure, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    top.plot(steps, [np.nan if row["tip_mean_mm"] is None else row["tip_mean_mm"]
                     for row in curve], "o-")
    top.set_ylabel("tip to interface (mm)")
    bottom.plot(steps, [row["success_rate"] for row in curve], "o-", color="tab:green")
    bottom.set_ylim(-0.05, 1.05)
    bottom.set_ylabel("success rate")
    bottom.set_xlabel("env steps (the first round the expert's)")
    figure.tight_layout()
    write_atomic(path, figure_png(figure, dpi=100))
    plt.close(figure)
