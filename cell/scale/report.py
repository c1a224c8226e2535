"""What a sweep shows a person: the outcomes against each swept variable (PNG) and a short
Markdown summary (how often the muscles separate cleanly, where runs fail).

Plots need matplotlib (the ``scale`` extra); it is imported only when they are drawn.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cell.extras import require
from cell.outputs import figure_png, write_atomic
from cell.scale.runs import OUTCOMES
from envs.settings import CUT_TASK

#: A run separates cleanly when the muscles come apart with at most this fraction of the
#: bindings torn rather than cut: the Cut env's own bound.
MAX_TORN_FRACTION = CUT_TASK.max_torn_fraction
#: A variable with more distinct values than this is summarised in quartile bins.
_MAX_LEVELS = 8
_LABELS = {"released_fraction": "released fraction", "torn_fraction": "torn fraction",
           "knife_force_peak_n": "peak knife force (N)"}


def clean(row: dict[str, Any]) -> bool:
    """The run ended, the muscles are apart and few bindings tore.

    Example:
        >>> clean({"status": "ok", "separated": True, "torn_fraction": 0.1})
        True
    """
    return (row.get("status") == "ok" and bool(row.get("separated"))
            and float(row.get("torn_fraction", 1.0)) <= MAX_TORN_FRACTION)


def write_plots(folder: Path, rows: Sequence[dict[str, Any]], variables: Sequence[str]
                ) -> list[Path]:
    """One PNG per swept variable, ``<variable>.png`` in ``folder``: each outcome of
    :data:`~cell.scale.runs.OUTCOMES` against the variable, finished runs as dots, runs that
    diverged or failed as red crosses on the x axis."""
    require("matplotlib", "scale", "the sweep's plots")
    from matplotlib.figure import Figure  # off pyplot: headless, nothing to close

    paths = []
    finished = [row for row in rows if row.get("status") == "ok"]
    broken = [row for row in rows if row.get("status") != "ok"]
    for variable in variables:
        figure = Figure(figsize=(4.0 * len(OUTCOMES), 3.4), layout="constrained")
        for ax, outcome in zip(figure.subplots(1, len(OUTCOMES)), OUTCOMES, strict=True):
            ax.plot([row[variable] for row in finished],
                    [row[outcome] for row in finished], "o", color="tab:blue",
                    alpha=0.7, label="finished")
            if broken:  # on the x axis itself, below every finished run's dot
                ax.plot([row[variable] for row in broken], [0.0] * len(broken), "x",
                        color="tab:red", markersize=9, clip_on=False,
                        transform=ax.get_xaxis_transform(), label="diverged or failed")
            ax.set_xlabel(variable)
            ax.set_ylabel(_LABELS[outcome])
        figure.legend(*ax.get_legend_handles_labels(), loc="outside upper center", ncols=2)
        paths.append(write_atomic(folder / f"{variable}.png", figure_png(figure)))
    return paths


def summary_markdown(title: str, rows: Sequence[dict[str, Any]], variables: Sequence[str],
                     plots: Sequence[Path]) -> str:
    """The sweep's summary: runs by status, how many separated cleanly, a table per swept
    variable, the plots and the runs that failed."""
    statuses = {s: sum(row.get("status") == s for row in rows) for s in ("ok", "diverged",
                                                                        "failed")}
    cleanly = sum(clean(row) for row in rows)
    lines = [f"# Sweep {title}", "",
             f"{len(rows)} runs: {statuses['ok']} finished, {statuses['diverged']} diverged, "
             f"{statuses['failed']} failed. Separated cleanly (muscles apart, at most "
             f"{MAX_TORN_FRACTION:.0%} of the bindings torn): {cleanly} of {len(rows)} "
             f"({cleanly / max(len(rows), 1):.0%}).", ""]
    for variable in variables:
        lines += [f"## {variable}", "",
                  "| value | runs | separated cleanly | released (mean) | torn (mean) "
                  "| peak knife force (mean, N) | diverged or failed |",
                  "|---|---|---|---|---|---|---|"]
        for label, group in _levels(rows, variable):
            done = [row for row in group if row.get("status") == "ok"]
            means = [f"{np.mean([row[o] for row in done]):.3g}" if done else "-"
                     for o in OUTCOMES]
            lines.append(f"| {label} | {len(group)} | {sum(map(clean, group))} | "
                         f"{' | '.join(means)} | {len(group) - len(done)} |")
        lines.append("")
    lines += [f"![{path.stem}]({path.name})" for path in plots] + [""]
    broken = [row for row in rows if row.get("status") != "ok"]
    if broken:
        lines += ["## Runs that did not finish", ""]
        lines += [f"- run {row['run']} ({', '.join(f'{v} = {row[v]}' for v in variables)}): "
                  f"{row['status']}: {row.get('error', '')}" for row in broken] + [""]
    return "\n".join(lines)


def _levels(rows: Sequence[dict[str, Any]], variable: str
            ) -> list[tuple[str, list[dict[str, Any]]]]:
    """The rows grouped by the variable's value, or by its quartile when it takes many."""
    values = sorted({row[variable] for row in rows}, key=lambda v: (str(type(v)), v))
    if len(values) <= _MAX_LEVELS or not all(isinstance(v, int | float) for v in values):
        return [(f"{value:.4g}" if isinstance(value, float) else str(value),
                 [row for row in rows if row[variable] == value]) for value in values]
    edges = np.quantile(values, [0.0, 0.25, 0.5, 0.75, 1.0])
    groups = []
    for k, (low, high) in enumerate(itertools.pairwise(edges)):
        last = k == len(edges) - 2
        group = [row for row in rows
                 if low <= row[variable] and (row[variable] < high or last)]
        groups.append((f"[{low:.4g}, {high:.4g}{']' if last else ')'}", group))
    return groups
