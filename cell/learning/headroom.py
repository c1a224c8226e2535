"""What ``Steer-v2`` leaves to gain before any training: its baselines on the same seeds (no
steering, the steering rule tuned on tuning seeds, and the ceiling that steers on the true
interface), each episode's tip-to-interface distance and outcome, the table with 95 %
intervals and the paired differences.

Seeds: the rule is tuned on :data:`RULE_TUNING_SEED_START` on (no test, evaluation or
constant search uses them), the table is measured on the evaluation seeds (100000 on).
"""

from __future__ import annotations

import itertools
import multiprocessing
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cell.errors import LearningError
from cell.learning.environments import START_METHOD, make_env
from cell.learning.paired import paired_mean_difference, paired_success_difference
from cell.learning.table import mean_interval, wilson
from envs.policies import SteeringKnife, TableSkimmingKnife, true_interface_policy

#: The env the baselines play (every ``Steer`` version's worlds and rollouts are the same; a
#: learned policy plays the version it was trained on).
ENV_ID = "musclecell/Steer-v2"
#: First seed of the episodes that tune the steering rule.
RULE_TUNING_SEED_START = 300_000
#: First seed of the episodes that choose among a training run's networks (tuning seeds
#: that neither the rule's tuning nor the probes on the benchmarks page played).
VALIDATION_SEED_START = 300_300
#: The rule's settings tried by :func:`tune_rule`: every combination.
RULE_GRID: dict[str, tuple[float, ...]] = {
    "load_sign": (1.0, -1.0),
    "gain_m_per_n_s": (0.001, 0.003, 0.01),
    "on_interface_load_n": (0.0,),
    "weak_side_gain": (1.0, 4.0),
}
#: The baselines by name.
BASELINES = ("no-steering", "rule", "ceiling")


@dataclass(frozen=True)
class SteerEpisode:
    """One episode to play: the baseline's name (or ``learned``), the rule's settings (for
    ``rule``), the seed, the env's keyword arguments and the learned policy's folder (for
    ``learned``)."""

    policy: str
    rule: tuple[tuple[str, float], ...]
    seed: int
    env_kwargs: tuple[tuple[str, Any], ...] = ()
    learned: str = ""


def play(task: SteerEpisode) -> dict[str, Any]:
    """One episode of ``task``: its outcome and the tip's distance to the interface.

    Raises:
        LearningError: a learned policy of an env that is not a version of ``Steer``.
    """
    learned = None
    if task.policy == "learned":
        from cell.learning.baselines import load_learned

        learned = load_learned(task.learned)
        if learned.env_id not in SteeringKnife.fits:
            raise LearningError(Path(task.learned), "env_id", f"the policy is of "
                                f"{learned.env_id}, not of {' or '.join(SteeringKnife.fits)}")
    env = make_env(ENV_ID if learned is None else learned.env_id, dict(task.env_kwargs))
    if task.policy == "ceiling":
        policy = true_interface_policy(env)
    elif learned is not None:
        policy = learned
    elif task.policy == "rule":
        policy = SteeringKnife(**dict(task.rule))
    else:
        policy = TableSkimmingKnife(limits=env.unwrapped.limits)
    obs, info = env.reset(seed=task.seed)
    done = False
    while not done:
        obs, _, terminated, truncated, info = env.step(policy(obs))
        done = terminated or truncated
    env.close()
    return {"policy": task.policy, "rule": dict(task.rule), "seed": task.seed,
            "tip_mean_mm": _mm(info["tip_distance_mean_m"]),
            "tip_max_mm": _mm(info["tip_distance_max_m"]), "success": bool(info["is_success"]),
            "torn_fraction": float(info["torn_fraction"]),
            "released_fraction": float(info["released_fraction"]),
            "elapsed_s": float(info["elapsed_s"]), "path_error": info["path_error"]}


def _mm(metres: float | None) -> float | None:
    """Millimetres; None for an episode whose tip never came across from the interface."""
    return None if metres is None else 1e3 * metres


def _tips(rows: Sequence[Mapping[str, Any]]) -> np.ndarray:
    """The rows' mean tip distances (mm), NaN where unscored."""
    return np.array([np.nan if row["tip_mean_mm"] is None else row["tip_mean_mm"]
                     for row in rows], float)


def play_all(tasks: Sequence[SteerEpisode], workers: int) -> list[dict[str, Any]]:
    """``tasks`` in ``workers`` processes, in order."""
    if workers <= 1:
        return [play(task) for task in tasks]
    with multiprocessing.get_context(START_METHOD).Pool(workers) as pool:
        return pool.map(play, tasks, chunksize=1)


def rule_settings() -> list[dict[str, float]]:
    """Every combination of :data:`RULE_GRID`."""
    names = list(RULE_GRID)
    return [dict(zip(names, values, strict=True))
            for values in itertools.product(*RULE_GRID.values())]


def tune_rule(episodes: int, workers: int, env_kwargs: Mapping[str, Any]
              ) -> dict[str, Any]:
    """Each of :func:`rule_settings` on ``episodes`` tuning seeds; the chosen one has the
    least mean tip distance among those whose success rate is no lower than no steering's
    on the same seeds."""
    seeds = range(RULE_TUNING_SEED_START, RULE_TUNING_SEED_START + episodes)
    kwargs = tuple(sorted(env_kwargs.items()))
    settings = rule_settings()
    tasks = [SteerEpisode("no-steering", (), seed, kwargs) for seed in seeds]
    tasks += [SteerEpisode("rule", tuple(sorted(rule.items())), seed, kwargs)
              for rule in settings for seed in seeds]
    rows = play_all(tasks, workers)
    plain = rows[:episodes]
    floor = np.mean([row["success"] for row in plain])
    scores = []
    for index, rule in enumerate(settings):
        mine = rows[episodes * (index + 1):episodes * (index + 2)]
        scores.append({"rule": rule, "tip_mean_mm": float(np.nanmean(_tips(mine))),
                       "success_rate": float(np.mean([row["success"] for row in mine]))})
    allowed = [score for score in scores if score["success_rate"] >= floor] or scores
    chosen = min(allowed, key=lambda score: score["tip_mean_mm"])
    return {"seeds": [seeds.start, seeds.stop - 1], "no_steering": {
        "tip_mean_mm": float(np.nanmean(_tips(plain))),
        "success_rate": float(floor)}, "scores": scores, "chosen": chosen["rule"]}


def choose_learned(folders: Sequence[str], seeds: Sequence[int], workers: int,
                   env_kwargs: Mapping[str, Any]) -> dict[str, Any]:
    """The learned policy among ``folders`` (one training run's networks) with the least mean
    tip distance on ``seeds`` (validation seeds, :data:`VALIDATION_SEED_START` on), over the
    seeds every one of them scored; a tie, or no such seed, goes to the first. Returns each
    one's mean tip distance and success rate and the ``chosen`` folder."""
    kwargs = tuple(sorted(env_kwargs.items()))
    rows = play_all([SteerEpisode("learned", (), seed, kwargs, folder)
                     for folder in folders for seed in seeds], workers)
    tips = _tips(rows).reshape(len(folders), len(seeds))
    successes = np.array([row["success"] for row in rows]).reshape(len(folders), len(seeds))
    scored = np.isfinite(tips).all(axis=0)
    scores = [{"folder": folder, "tip_mean_mm": float(tips[index, scored].mean())
               if scored.any() else None,
               "success_rate": float(successes[index].mean())}
              for index, folder in enumerate(folders)]
    chosen = min(scores, key=lambda score: score["tip_mean_mm"] or 0.0)
    return {"seeds": [min(seeds), max(seeds)], "tip_scored_on": int(scored.sum()),
            "scores": scores, "chosen": chosen["folder"]}


def baseline_table(rule: Mapping[str, float], seeds: Sequence[int], workers: int,
                   env_kwargs: Mapping[str, Any], learned: str = "") -> dict[str, Any]:
    """The three baselines (and the policy of the run folder ``learned``, if given) on
    ``seeds``, as :func:`report_of` reports them."""
    kwargs = tuple(sorted(env_kwargs.items()))
    names = (*BASELINES, "learned") if learned else BASELINES
    tasks = [SteerEpisode(name, tuple(sorted(rule.items())) if name == "rule" else (), seed,
                          kwargs, learned) for name in names for seed in seeds]
    return report_of(play_all(tasks, workers), rule)


def report_of(rows: Sequence[Mapping[str, Any]], rule: Mapping[str, float]) -> dict[str, Any]:
    """The report of the episodes ``rows`` (as :func:`play` gives them, every policy on the
    same seeds in the same order): per policy the mean tip distance (mm), its max, the torn
    fraction, the time and the cycle time (s, over its successes) with 95 % t intervals, the
    success rate with its Wilson interval; the paired differences of each (rule less no
    steering, ceiling less rule, ceiling less no steering, learned less rule): the tip
    distance on the seeds both scored, the cycle time on the seeds both succeeded on (a
    failed episode ends at its stop, often in the entry: no cycle to time); and every
    episode."""
    by_name: dict[str, list[Mapping[str, Any]]] = {}
    for row in rows:
        by_name.setdefault(row["policy"], []).append(row)
    pairs = {}
    compared = [("rule", "no-steering"), ("ceiling", "rule"), ("ceiling", "no-steering"),
                ("learned", "rule")]
    for better, worse in (pair for pair in compared if set(pair) <= set(by_name)):
        mine, theirs = by_name[better], by_name[worse]
        tips, their_tips = _tips(mine), _tips(theirs)
        scored = np.isfinite(tips) & np.isfinite(their_tips)
        both = [(a["elapsed_s"], b["elapsed_s"]) for a, b in zip(mine, theirs, strict=True)
                if a["success"] and b["success"]]
        pairs[f"{better} - {worse}"] = {
            "tip_mean_mm": paired_mean_difference(list(tips[scored]), list(their_tips[scored]))
            if scored.any() else None,
            "tip_scored_on": int(scored.sum()),
            "success": paired_success_difference([row["success"] for row in mine],
                                                 [row["success"] for row in theirs]),
            **{key: paired_mean_difference([row[key] for row in mine],
                                           [row[key] for row in theirs])
               for key in ("torn_fraction", "elapsed_s")},
            "cycle_time_s": paired_mean_difference(*map(list, zip(*both, strict=True)))
            if both else None,
            "cycle_time_on": len(both)}
    seeds = [row["seed"] for row in rows]
    return {"env": ENV_ID, "seeds": [min(seeds), max(seeds)], "rule": dict(rule),
            "table": {name: _summary(mine) for name, mine in by_name.items()},
            "paired": pairs, "episodes": list(rows)}


def _summary(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """One policy's row; the tip's distances over the episodes that scored it (a protective
    stop at the entry ends an episode before the tip comes across from the interface)."""
    successes = sum(row["success"] for row in rows)
    scored = [row for row in rows if row["tip_mean_mm"] is not None]
    return {"episodes": len(rows), "successes": successes,
            "success_rate": successes / len(rows), "success_interval": wilson(successes,
                                                                              len(rows)),
            "tip_unscored": len(rows) - len(scored),
            **{key: mean_interval([row[key] for row in scored]) if scored else None
               for key in ("tip_mean_mm", "tip_max_mm")},
            **{key: mean_interval([row[key] for row in rows])
               for key in ("torn_fraction", "elapsed_s")},
            "cycle_time_s": mean_interval([row["elapsed_s"] for row in rows if row["success"]])
            if successes else None}


def summary_lines(evaluation: Mapping[str, Any]) -> list[str]:
    """:func:`report_of`'s report in lines to print: each policy's tip distance, success and
    torn fraction, then each paired difference's tip distance, success, torn fraction and
    cycle time."""
    lines = []
    for name, row in evaluation["table"].items():
        lines.append(f"{name}: tip {_interval(row['tip_mean_mm'], '.2f')} mm "
                     f"({row['episodes'] - row['tip_unscored']} scored), success "
                     f"{row['successes']}/{row['episodes']}, torn "
                     f"{row['torn_fraction']['mean']:.3f}")
    for pair, difference in evaluation["paired"].items():
        success = difference["success"]
        lines.append(f"{pair}: tip {_interval(difference['tip_mean_mm'], '+.2f')} mm on "
                     f"{difference['tip_scored_on']} seeds, success "
                     f"{success['difference']:+.2f} [{success['low']:+.2f}, "
                     f"{success['high']:+.2f}], torn "
                     f"{_interval(difference['torn_fraction'], '+.3f')}, cycle time "
                     f"{_interval(difference['cycle_time_s'], '+.2f')} s on "
                     f"{difference['cycle_time_on']} seeds")
    return lines


def _interval(value: Mapping[str, float | None] | None, spec: str) -> str:
    """A mean and its interval as text ("-" for what is not there)."""
    if value is None:
        return "-"
    low, high = (("-" if value[key] is None else format(value[key], spec))
                 for key in ("low", "high"))
    return f"{format(value['mean'], spec)} [{low}, {high}]"
