"""Two policies compared on the same seeds: the difference of their success rates and of their
mean torn fractions, each with a 95 % interval that uses the pairing (an episode's world is
the same for both, so the per-seed outcomes are correlated and a paired interval is narrower
than one of two independent samples).

Success: Newcombe's square-and-add interval for paired proportions (Newcombe 1998, method 10:
the two Wilson score intervals combined with the correlation of the paired outcomes), and the
exact McNemar test of the discordant seeds. Means: the Student-t interval of the per-seed
differences.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from scipy import stats

from cell.learning.table import SCORED_COLUMNS, mean_interval, wilson

#: The outcome columns compared as per-seed differences of means.
PAIRED_MEANS = ("torn_fraction", "released_fraction")


def _correlation(both: int, first_only: int, second_only: int, neither: int) -> float:
    """Newcombe's estimate of the correlation of the two success indicators: the phi
    coefficient with the numerator moved toward zero by half the sample size when positive
    (zero when a margin is empty)."""
    n = both + first_only + second_only + neither
    margins = ((both + first_only) * (second_only + neither) * (both + second_only)
               * (first_only + neither))
    if margins == 0:
        return 0.0
    cross = both * neither - first_only * second_only
    if cross > n / 2:
        return (cross - n / 2) / math.sqrt(margins)
    return cross / math.sqrt(margins) if cross < 0 else 0.0


def paired_success_difference(first: Sequence[bool], second: Sequence[bool]
                              ) -> dict[str, Any]:
    """The success rate of ``first`` less that of ``second`` (outcomes of the same seeds, in
    the same order) with its 95 % interval (Newcombe's square-and-add for paired
    proportions), the discordant seeds' counts and the two-sided exact McNemar p-value.

    Example:
        >>> result = paired_success_difference([True, True, False, True], [True, False, False,
        ...                                                                 False])
        >>> result["difference"], result["first_only"], result["second_only"]
        (0.5, 2, 0)
    """
    if len(first) != len(second) or not first:
        raise ValueError(f"need paired outcomes of the same seeds, got {len(first)} and "
                         f"{len(second)}")
    pairs = [(bool(a), bool(b)) for a, b in zip(first, second, strict=True)]
    both = pairs.count((True, True))
    first_only = pairs.count((True, False))
    second_only = pairs.count((False, True))
    neither = pairs.count((False, False))
    n = len(pairs)
    p1, p2 = (both + first_only) / n, (both + second_only) / n
    low1, high1 = wilson(both + first_only, n)
    low2, high2 = wilson(both + second_only, n)
    phi = _correlation(both, first_only, second_only, neither)
    difference = p1 - p2
    below = math.sqrt(max(0.0, (p1 - low1) ** 2 + (high2 - p2) ** 2
                          - 2 * phi * (p1 - low1) * (high2 - p2)))
    above = math.sqrt(max(0.0, (p2 - low2) ** 2 + (high1 - p1) ** 2
                          - 2 * phi * (p2 - low2) * (high1 - p1)))
    discordant = first_only + second_only
    p_value = (1.0 if discordant == 0 else
               float(stats.binomtest(first_only, discordant, 0.5).pvalue))
    return {"difference": difference, "low": difference - below, "high": difference + above,
            "both": both, "first_only": first_only, "second_only": second_only,
            "neither": neither, "mcnemar_p": p_value}


def paired_mean_difference(first: Sequence[float], second: Sequence[float]
                           ) -> dict[str, float | None]:
    """The mean of the per-seed differences ``first - second`` with its 95 % Student-t
    interval (:func:`~cell.learning.table.mean_interval` of the differences).

    Example:
        >>> paired_mean_difference([0.1, 0.2, 0.3], [0.0, 0.1, 0.3])["mean"]
        0.0666...
    """
    if len(first) != len(second) or not first:
        raise ValueError(f"need paired values of the same seeds, got {len(first)} and "
                         f"{len(second)}")
    return mean_interval([a - b for a, b in zip(first, second, strict=True)])


def compare(rows: Sequence[Mapping[str, Any]], policy: str, other: str) -> dict[str, Any]:
    """``policy`` against ``other`` on the seeds both played (episode rows with ``policy``,
    ``seed``, ``success`` and the :data:`PAIRED_MEANS`): the paired success difference and
    the paired difference of each mean, ``policy`` minus ``other``; and of each of the
    :data:`~cell.learning.table.SCORED_COLUMNS` the rows have, on the seeds both scored
    (with ``scored_on``, their count).

    Example:
        >>> rows = [{"policy": p, "seed": s, "success": p == "a", "torn_fraction": 0.1,
        ...          "released_fraction": 1.0} for p in "ab" for s in range(3)]
        >>> compare(rows, "a", "b")["success"]["difference"]
        1.0
    """
    by_seed = {name: {row["seed"]: row for row in rows if row["policy"] == name}
               for name in (policy, other)}
    seeds = sorted(set(by_seed[policy]) & set(by_seed[other]))
    mine, theirs = ([by_seed[name][seed] for seed in seeds] for name in (policy, other))
    return {"policy": policy, "against": other, "episodes": len(seeds),
            "success": paired_success_difference([row["success"] for row in mine],
                                                 [row["success"] for row in theirs]),
            **{column: paired_mean_difference([row[column] for row in mine],
                                              [row[column] for row in theirs])
               for column in PAIRED_MEANS},
            **{column: _scored_difference([(a[column], b[column])
                                           for a, b in zip(mine, theirs, strict=True)])
               for column in SCORED_COLUMNS if mine and column in mine[0]}}


def _scored_difference(pairs: Sequence[tuple[float | None, float | None]]
                       ) -> dict[str, float | int | None]:
    """:func:`paired_mean_difference` over the pairs where both scored (not None)."""
    scored = [(a, b) for a, b in pairs if a is not None and b is not None]
    if not scored:
        return {"mean": None, "low": None, "high": None, "scored_on": 0}
    first, second = zip(*scored, strict=True)
    return {**paired_mean_difference(list(first), list(second)), "scored_on": len(scored)}


def comparison_markdown(comparison: Mapping[str, Any]) -> str:
    """The comparison as a short Markdown paragraph and table.

    Example:
        >>> rows = [{"policy": p, "seed": s, "success": p == "a", "torn_fraction": 0.1,
        ...          "released_fraction": 1.0} for p in "ab" for s in range(3)]
        >>> print(comparison_markdown(compare(rows, "a", "b")).splitlines()[-3])
        | success rate | +1 [0.206, 1] | a only: 3, b only: 0, McNemar p = 0.25 |
    """
    policy, other = comparison["policy"], comparison["against"]
    success = comparison["success"]
    lines = [f"Paired on the same {comparison['episodes']} seeds: {policy} less {other}, "
             "95 % intervals (success: Newcombe's paired square-and-add; means: Student-t of "
             "the per-seed differences).", "",
             "| score | difference | |", "|---|---|---|",
             f"| success rate | {success['difference']:+.3g} [{success['low']:.3g}, "
             f"{success['high']:.3g}] | {policy} only: {success['first_only']}, {other} only: "
             f"{success['second_only']}, McNemar p = {success['mcnemar_p']:.3g} |"]
    for column in (*PAIRED_MEANS, *(c for c in SCORED_COLUMNS if c in comparison)):
        entry = comparison[column]
        name = SCORED_COLUMNS.get(column, column.replace("_", " "))
        note = f"on the {entry['scored_on']} seeds both scored" if "scored_on" in entry else ""
        if entry["mean"] is None:
            lines.append(f"| {name} | - | {note} |")
            continue
        interval = ("" if entry["low"] is None
                    else f" [{entry['low']:.3g}, {entry['high']:.3g}]")
        lines.append(f"| {name} | {entry['mean']:+.3g}{interval} | {note} |")
    return "\n".join(lines) + "\n"
