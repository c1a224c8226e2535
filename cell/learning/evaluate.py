"""The evaluation of a learned policy beside the random, the best constant and the scripted
policy and the hand-written demonstrators that fit the env, on the same seeds, episodes side
by side in worker processes; the learned policy is compared with the best demonstrator on
those seeds, paired (:mod:`cell.learning.paired`). Without a learned policy the baselines'
rows alone.

Seeds: the evaluation episodes are ``reset(seed=k)`` for ``k`` from ``seed_start``
(:data:`EVAL_SEED_START` by default, above every training seed) on; the best constant action is
chosen on the tuning seeds from :data:`TUNING_SEED_START` on, by success rate then mean
return, and then evaluated on the evaluation seeds like the others. Each episode is
independent of the others and of the worker that plays it, so the table depends only on the
inputs.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from cell.cores import default_workers
from cell.errors import LearningError
from cell.learning.baselines import (
    BASELINES,
    LEARNED,
    PolicySpec,
    constant_grid,
    constant_pairs,
    load_learned,
    make_policy,
    policy_folder,
)
from cell.learning.environments import START_METHOD, WITHOUT_RAY, make_env
from cell.learning.hyper import EVAL_SEED_START, TUNING_SEED_START
from cell.learning.paired import compare, comparison_markdown
from cell.learning.table import SCORED_COLUMNS, markdown, summarize
from cell.outputs import json_text, rows_text, write_together
from envs.policies import demonstrators_for, episode_return

#: Keys of the final step's info that each episode's row keeps, by column (``success`` is
#: the info's ``is_success``).
#: Times Ray plays an episode again whose worker was lost (its process or node died).
LOST_TASK_RETRIES = 3
INFO_COLUMNS = ("success", "released_fraction", "torn_fraction", "knife_force_peak_n",
                "flesh_damage_s", "elapsed_s", "diverged", "protective_stop")
#: Columns of the episodes CSV (a scored column blank for an env without it, or an
#: episode that did not score it).
EPISODE_COLUMNS = ("policy", "seed", "return", *INFO_COLUMNS, *SCORED_COLUMNS, "wall_s")


@dataclass(frozen=True)
class EvaluationSettings:
    """How an evaluation runs.

    Attributes:
        episodes: evaluation episodes per policy, seeds ``seed_start`` on.
        seed_start: first evaluation seed, from :data:`EVAL_SEED_START` up, with the
            evaluation's seeds below :data:`TUNING_SEED_START`.
        workers: processes playing episodes (1: in this process).
        constant_search_seeds: episodes per constant action on the tuning seeds.
        constant_actions: the constant actions to choose from (None: a search in two
            rounds, :func:`~cell.learning.baselines.constant_grid` of the env's action size,
            then :func:`~cell.learning.baselines.constant_pairs` of the first round's best).

    Example:
        >>> EvaluationSettings(episodes=2, workers=1).seed_start
        100000
    """

    episodes: int = 50
    seed_start: int = EVAL_SEED_START
    workers: int = field(default_factory=default_workers)
    constant_search_seeds: int = 10
    constant_actions: tuple[tuple[float, ...], ...] | None = None

    def __post_init__(self) -> None:
        for name in ("episodes", "workers", "constant_search_seeds"):
            if not getattr(self, name) >= 1:
                raise LearningError(None, f"--{name.replace('_', '-')}",
                                    f"must be >= 1, got {getattr(self, name)}")
        if not (self.seed_start >= EVAL_SEED_START
                and self.seed_start + self.episodes <= TUNING_SEED_START):
            raise LearningError(None, "--seed-start", f"the evaluation's seeds must lie in "
                                f"{EVAL_SEED_START}..{TUNING_SEED_START - 1}, got "
                                f"{self.seed_start}..{self.seed_start + self.episodes - 1}")

    @property
    def seeds(self) -> range:
        """The evaluation's seeds."""
        return range(self.seed_start, self.seed_start + self.episodes)

    @property
    def tuning_seeds(self) -> range:
        """The seeds the best constant action is chosen on."""
        return range(TUNING_SEED_START, TUNING_SEED_START + self.constant_search_seeds)


def parse_constant_actions(text: str | None) -> tuple[tuple[float, ...], ...] | None:
    """The constant actions of ``--constant-actions`` (a JSON list of actions), None for None.

    Example:
        >>> parse_constant_actions("[[0, 0], [1, 0]]")
        ((0.0, 0.0), (1.0, 0.0))
    """
    if text is None:
        return None
    try:
        actions = tuple(tuple(float(a) for a in action) for action in json.loads(text))
    except (json.JSONDecodeError, TypeError, ValueError) as exc:
        raise LearningError(None, "--constant-actions", f"need a JSON list of actions (lists "
                            f"of numbers): {exc}") from None
    if not actions:
        raise LearningError(None, "--constant-actions", "need at least one action")
    return actions


@dataclass(frozen=True)
class EpisodeTask:
    """One episode to play: the env (id and JSON of its keyword arguments), policy, seed."""

    env_id: str
    env_kwargs_json: str
    policy: PolicySpec
    seed: int


@lru_cache(maxsize=2)  # one env per worker process, reset for each of its episodes
def _env(env_id: str, env_kwargs_json: str) -> gym.Env:
    return make_env(env_id, json.loads(env_kwargs_json))


def run_episode(task: EpisodeTask) -> dict[str, Any]:
    """Play one episode; its row: policy, seed, return, :data:`INFO_COLUMNS` from the final
    step's info, the tip's mean distance to the true interface (``tip_distance_mm``, None
    when unscored) where the env gives it (``Steer-v2``), wall time (s)."""
    started = time.perf_counter()
    env = _env(task.env_id, task.env_kwargs_json)
    total, info = episode_return(env, make_policy(task.policy, env, task.seed), task.seed)
    row = {"policy": task.policy.name, "seed": task.seed, "return": total}
    for key in INFO_COLUMNS:
        value = info["is_success" if key == "success" else key]
        row[key] = bool(value) if isinstance(value, bool | np.bool_) else float(value)
    if "tip_distance_mean_m" in info:
        tip = info["tip_distance_mean_m"]
        row["tip_distance_mm"] = None if tip is None else 1e3 * float(tip)
    return {**row, "wall_s": time.perf_counter() - started}


def _one_thread() -> None:
    """Worker set-up: episodes run side by side, a core each, so torch's own threads (it
    reads the variable at its import, in the worker's first learned episode) would only
    compete with them."""
    os.environ["OMP_NUM_THREADS"] = "1"


@contextmanager
def episode_runner(workers: int, play: Callable[[Any], dict[str, Any]] = run_episode,
                   on_episode: Callable[[int], object] | None = None,
                   address: str | None = None
                   ) -> Iterator[Callable[[list[Any]], list[dict[str, Any]]]]:
    """A function that plays a list of tasks with ``play`` (by default :func:`run_episode`)
    and returns their rows in the tasks' order, on ``workers`` processes (started once, for
    every list) or in this process for one, or with ``address`` as Ray tasks of one CPU on
    that cluster (``workers`` unused: the cluster's CPUs bound them; a task whose worker is
    lost is played again, from its seed, by Ray); ``on_episode`` is called with 1 as each
    row comes (progress).

    Example:
        >>> with episode_runner(1) as run:
        ...     run([])
        []
    """

    def counted(rows: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
        done = []
        for row in rows:
            done.append(row)
            if on_episode is not None:
                on_episode(1)
        return done

    if address is not None:
        from cell.rayconnect import ray_session

        with ray_session(address, "--address", WITHOUT_RAY) as ray:
            remote = ray.remote(num_cpus=1, max_retries=LOST_TASK_RETRIES)(play)
            yield lambda tasks: counted(ray.get(ref) for ref in
                                        [remote.remote(task) for task in tasks])
        return
    if workers == 1:
        yield lambda tasks: counted(map(play, tasks))
        return
    context = multiprocessing.get_context(START_METHOD)
    with ProcessPoolExecutor(workers, mp_context=context, initializer=_one_thread) as pool:
        yield lambda tasks: counted(pool.map(play, tasks))


def _check_policy(folder: Path, env: gym.Env) -> None:
    """The learned policy must act in ``env``'s action space."""
    network = load_learned(str(folder)).network
    for name in ("observation_space", "action_space"):
        trained, wanted = getattr(network, name).shape, getattr(env, name).shape
        if trained != wanted:
            raise LearningError(folder, "ENV", f"the policy's {name} is {trained}, the env's "
                                f"{wanted}")


def _choose_constant(grid: list[tuple[float, ...]], rows: list[dict[str, Any]]
                     ) -> dict[str, Any]:
    """The grid action with the best success rate, then mean return, and every score."""
    scores = []
    for action in grid:
        mine = [row for row in rows if tuple(row["action"]) == action]
        scores.append({"action": list(action),
                       "success_rate": float(np.mean([row["success"] for row in mine])),
                       "mean_return": float(np.mean([row["return"] for row in mine]))})
    best = max(scores, key=lambda score: (score["success_rate"], score["mean_return"]))
    return {"chosen": best, "scores": scores}


def _best_demonstrator(names: list[str], policies: dict[str, dict[str, Any]]) -> str:
    """The demonstrator of ``names`` with the best success rate, then mean return, on the
    evaluation seeds themselves (a choice that favours the demonstrators, not the learned
    policy)."""
    return max(names, key=lambda name: (policies[name]["success_rate"]["rate"],
                                        policies[name]["mean_return"]))


def evaluate(policy_path: str | Path | None, env_id: str, env_kwargs: dict[str, Any],
             settings: EvaluationSettings,
             on_episode: Callable[[int], object] | None = None) -> dict[str, Any]:
    """Tune the best constant action (see :class:`EvaluationSettings`), then play the
    :data:`~cell.learning.baselines.BASELINES`, the demonstrators that fit ``env_id``
    (:func:`envs.policies.demonstrators_for`) and the learned policy at ``policy_path``
    (none when None) on the evaluation seeds. The report holds the table
    (:func:`~cell.learning.table.summarize` per policy), the tuning, every episode's row
    (ordered by policy, then seed) and, with a learned policy and a demonstrator, their
    paired comparison (:func:`~cell.learning.paired.compare`, learned less the best
    demonstrator; None otherwise). ``on_episode`` is called with 1 after each episode
    (progress).

    Raises:
        LearningError: no policy at ``policy_path``, a policy of another env, a constant
            action of the wrong size or out of [-1, 1].
    """
    folder = None if policy_path is None else policy_folder(policy_path)
    env = make_env(env_id, env_kwargs)
    if folder is not None:
        _check_policy(folder, env)
    demonstrators = demonstrators_for(env_id)
    names = [*BASELINES, *demonstrators, *([LEARNED] if folder is not None else [])]
    dims = env.action_space.shape[0]
    env.close()
    grid = [tuple(map(float, a)) for a in settings.constant_actions or constant_grid(dims)]
    for action in grid:
        if len(action) != dims or not all(-1.0 <= a <= 1.0 for a in action):
            raise LearningError(None, "--constant-actions", f"{list(action)}: need {dims} "
                                f"values in [-1, 1]")
    kwargs_json = json.dumps(env_kwargs, sort_keys=True)

    def tuning(actions: list[tuple[float, ...]]) -> list[EpisodeTask]:
        return [EpisodeTask(env_id, kwargs_json, PolicySpec("constant", action), seed)
                for action in actions for seed in settings.tuning_seeds]

    def scored(tasks: list[EpisodeTask], rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
        return [{**row, "action": task.policy.action}
                for row, task in zip(rows, tasks, strict=True)]

    first = tuning(grid)
    others = [EpisodeTask(env_id, kwargs_json, PolicySpec(name, folder=str(folder)), seed)
              for name in names if name != "best-constant" for seed in settings.seeds]
    # The first round and the policies that need no tuning share one pool, then the second
    # round, then the chosen constant.
    with episode_runner(settings.workers, on_episode=on_episode) as run:
        rows = run(first + others)
        tuned = scored(first, rows[:len(first)])
        if settings.constant_actions is None:
            best = tuple(_choose_constant(grid, tuned)["chosen"]["action"])
            pairs = [a for a in constant_pairs(best) if a not in grid]
            second = tuning(pairs)
            tuned += scored(second, run(second))
            grid += pairs
        constant = _choose_constant(grid, tuned)
        chosen = PolicySpec("best-constant", tuple(constant["chosen"]["action"]))
        rows = rows[len(first):] + run(
            [EpisodeTask(env_id, kwargs_json, chosen, seed) for seed in settings.seeds])
    rows.sort(key=lambda row: (names.index(row["policy"]), row["seed"]))
    policies = {name: summarize([row for row in rows if row["policy"] == name])
                for name in names}
    comparison = None
    if folder is not None and demonstrators:
        comparison = {**compare(rows, LEARNED, _best_demonstrator(demonstrators, policies)),
                      "against_chosen_by": "the demonstrators' success rate, then mean "
                      "return, on these seeds"}
    return {"env_id": env_id, "env_kwargs": env_kwargs,
            "policy": None if folder is None else str(folder),
            "seeds": [settings.seed_start, settings.seed_start + settings.episodes - 1],
            "confidence": "95 %: Wilson for success rates, Student-t for means",
            "best_constant": {**constant, "tuning_seeds": [settings.tuning_seeds[0],
                                                           settings.tuning_seeds[-1]]},
            "demonstrators": demonstrators, "policies": policies,
            "comparison": comparison, "episodes": rows}


def report_markdown(report: dict[str, Any]) -> str:
    """The report as Markdown: what was evaluated on which seeds, the chosen constant action,
    the table."""
    chosen = report["best_constant"]["chosen"]
    first, last = report["seeds"]
    tuning_first, tuning_last = report["best_constant"]["tuning_seeds"]
    subject = "the baselines" if report["policy"] is None else report["policy"]
    comparison = report["comparison"]
    paired = ("" if comparison is None else "\n" + comparison_markdown(comparison))
    return (f"# Evaluation of {subject} on {report['env_id']}\n\n"
            f"Seeds {first}..{last} for every policy; env kwargs "
            f"`{json.dumps(report['env_kwargs'])}`. Best constant action "
            f"{chosen['action']} (success rate {chosen['success_rate']:.3g}, mean return "
            f"{chosen['mean_return']:.4g} on the tuning seeds {tuning_first}..{tuning_last}, "
            f"of {len(report['best_constant']['scores'])} candidates). Intervals: "
            f"{report['confidence']}.\n\n" + markdown(report["policies"]) + paired)


def write_report(report: dict[str, Any], json_path: Path, markdown_path: Path,
                 csv_path: Path) -> None:
    """Write the report as JSON, its table as Markdown and the episodes as CSV, as one change
    (:func:`cell.outputs.write_together`)."""
    write_together({json_path: json_text(report, json_path),
                    markdown_path: report_markdown(report),
                    csv_path: rows_text(EPISODE_COLUMNS, report["episodes"])})
