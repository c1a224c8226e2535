"""The evaluation's table: per policy, the success rate with its 95 % Wilson interval and the
means of the outcome columns with 95 % Student-t intervals (mean +- t(0.975, n - 1) times the
standard error; none for a single episode), as JSON-ready data and as Markdown."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from scipy import stats

#: Columns averaged per policy, from each episode's final info, with their headers.
MEAN_COLUMNS = {"released_fraction": "released", "torn_fraction": "torn",
                "knife_force_peak_n": "peak knife force (N)",
                "flesh_damage_s": "flesh damage (s)", "elapsed_s": "time (s)"}
#: Columns an env's final info may add (``Steer-v2``'s tip distance), averaged per policy
#: over the episodes that scored them (None: unscored), with their headers.
SCORED_COLUMNS = {"tip_distance_mm": "tip to interface (mm)"}
CONFIDENCE = 0.95


def wilson(successes: int, trials: int) -> tuple[float, float]:
    """The 95 % Wilson score interval of a success rate.

    Example:
        >>> low, high = wilson(5, 10)
        >>> round(low, 3), round(high, 3)
        (0.237, 0.763)
    """
    interval = stats.binomtest(successes, trials).proportion_ci(CONFIDENCE, method="wilson")
    return float(interval.low), float(interval.high)


def mean_interval(values: Sequence[float]) -> dict[str, float | None]:
    """Mean and its 95 % Student-t interval (None for the bounds of fewer than two values).

    Example:
        >>> mean_interval([1.0, 2.0, 3.0])
        {'mean': 2.0, 'low': -0.484..., 'high': 4.484...}
    """
    data = np.asarray(values, dtype=float)
    mean = float(data.mean())
    if len(data) < 2:
        return {"mean": mean, "low": None, "high": None}
    half = float(stats.t.ppf(0.5 + CONFIDENCE / 2, len(data) - 1)
                 * data.std(ddof=1) / math.sqrt(len(data)))
    return {"mean": mean, "low": mean - half, "high": mean + half}


def summarize(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The table entry of one policy's episodes: episodes, successes, the success rate with
    its interval, the mean return, the :data:`MEAN_COLUMNS` with theirs, divergences and
    protective stops, and the :data:`SCORED_COLUMNS` the rows have, over the rows that scored
    them (with ``scored``, their count; the mean None when none did).

    Example:
        >>> rows = [{"success": s, "return": 1.0, "diverged": False, "protective_stop": False,
        ...          **dict.fromkeys(MEAN_COLUMNS, 0.5)} for s in (True, False)]
        >>> summarize(rows)["success_rate"]["rate"]
        0.5
    """
    successes = sum(bool(row["success"]) for row in rows)
    low, high = wilson(successes, len(rows))
    return {"episodes": len(rows), "successes": successes,
            "success_rate": {"rate": successes / len(rows), "low": low, "high": high},
            "mean_return": float(np.mean([row["return"] for row in rows])),
            **{column: mean_interval([row[column] for row in rows]) for column in MEAN_COLUMNS},
            "diverged": sum(bool(row["diverged"]) for row in rows),
            "protective_stops": sum(bool(row["protective_stop"]) for row in rows),
            **{column: scored_interval([row[column] for row in rows])
               for column in SCORED_COLUMNS if column in rows[0]}}


def scored_interval(values: Sequence[float | None]) -> dict[str, float | int | None]:
    """:func:`mean_interval` of the values that are not None, and their count ``scored``.

    Example:
        >>> scored_interval([1.0, None, 3.0])
        {'mean': 2.0, 'low': -10.7..., 'high': 14.7..., 'scored': 2}
    """
    scored = [value for value in values if value is not None]
    if not scored:
        return {"mean": None, "low": None, "high": None, "scored": 0}
    return {**mean_interval(scored), "scored": len(scored)}


def _cell(entry: Mapping[str, float | None], key: str = "mean") -> str:
    if entry[key] is None:
        return "-"
    if entry["low"] is None:
        return f"{entry[key]:.3g}"
    return f"{entry[key]:.3g} [{entry['low']:.3g}, {entry['high']:.3g}]"


def markdown(policies: Mapping[str, Mapping[str, Any]]) -> str:
    """The table as Markdown, one row per policy, intervals in brackets.

    Example:
        >>> rows = [{"success": True, "return": 1.0, "diverged": False,
        ...          "protective_stop": False, **dict.fromkeys(MEAN_COLUMNS, 0.5)}]
        >>> print(markdown({"scripted": summarize(rows)}).splitlines()[2])
        | scripted | 1 | 1 [0.207, 1] | 0.5 | 0.5 | 0.5 | 0.5 | 0.5 | 1 | 0 | 0 |
    """
    scored = [column for column in SCORED_COLUMNS
              if any(column in entry for entry in policies.values())]
    header = ["policy", "episodes", "success rate", *MEAN_COLUMNS.values(),
              *(SCORED_COLUMNS[column] for column in scored), "mean return", "diverged",
              "protective stops"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for name, entry in policies.items():
        cells = [name, str(entry["episodes"]), _cell(entry["success_rate"], "rate"),
                 *(_cell(entry[column]) for column in MEAN_COLUMNS),
                 *(_cell(entry[column]) if column in entry else "" for column in scored),
                 f"{entry['mean_return']:.3g}", str(entry["diverged"]),
                 str(entry["protective_stops"])]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
