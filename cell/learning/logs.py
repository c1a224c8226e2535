"""A training run's logs: PPO's progress table and the episodes table as CSV, and the learning
curve as a PNG, each rewritten whole (atomically) so that a reader never sees half a file and
a resumed run carries on from what is there."""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.logger import KVWriter

from cell.outputs import figure_png, write_atomic, write_rows

#: Columns of the episodes table: env steps of the run when the episode ended, its return and
#: length (env steps), and the final step's outcome.
EPISODE_COLUMNS = ("steps", "return", "length", "success", "released_fraction",
                   "torn_fraction")
#: Episodes per point of the learning curve's moving average.
CURVE_WINDOW = 20


def read_rows(path: Path) -> list[dict[str, str]]:
    """The rows of a CSV file written by :func:`write_rows` (none if it is not there)."""
    if not path.exists():
        return []
    with path.open(newline="") as file:
        return list(csv.DictReader(file))


class ProgressCsv(KVWriter):
    """Stable-Baselines3's logged values, one row per update, as a CSV file rewritten at each
    update (a resumed run keeps the rows it finds; a key seen later adds a column)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.rows: list[dict[str, Any]] = read_rows(path)
        self.columns: list[str] = list(self.rows[0]) if self.rows else []

    def write(self, key_values: dict[str, Any], key_excluded: dict[str, tuple[str, ...]],
              step: int = 0) -> None:
        """Add a row of the values not excluded from CSV, and rewrite the file."""
        row = {key: value for key, value in key_values.items()
               if "csv" not in (key_excluded.get(key) or ())}
        self.columns += [key for key in row if key not in self.columns]
        self.rows.append(row)
        write_rows(self.path, self.columns, self.rows)

    def close(self) -> None:
        """Nothing held open: each write wrote the whole file."""


class EpisodeLog:
    """The training episodes, one row each (:data:`EPISODE_COLUMNS`), kept in memory and
    written as CSV and as a learning curve on request."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.rows: list[dict[str, Any]] = read_rows(path)

    def add(self, steps: int, info: Mapping[str, Any]) -> None:
        """Log the episode that ended with ``info`` (the final step's, with ``VecMonitor``'s
        ``episode`` entry) at ``steps`` env steps of the run."""
        self.rows.append({"steps": steps, "return": info["episode"]["r"],
                          "length": info["episode"]["l"], "success": int(info["is_success"]),
                          "released_fraction": info["released_fraction"],
                          "torn_fraction": info["torn_fraction"]})

    def write(self, curve: Path) -> None:
        """Rewrite the CSV and the learning curve PNG at ``curve``."""
        write_rows(self.path, EPISODE_COLUMNS, self.rows)
        write_atomic(curve, learning_curve_png(self.rows))


def moving_average(values: np.ndarray, window: int) -> np.ndarray:
    """Mean of the last ``window`` values (fewer at the start) at each index.

    Example:
        >>> moving_average(np.array([1.0, 3.0, 5.0]), 2)
        array([1., 2., 4.])
    """
    sums = np.cumsum(np.insert(values, 0, 0.0))
    index = np.arange(1, len(values) + 1)
    start = np.maximum(index - window, 0)
    return (sums[index] - sums[start]) / (index - start)


def learning_curve_png(rows: Sequence[Mapping[str, Any]]) -> bytes:
    """Episode return and success rate against env steps (moving averages over
    :data:`CURVE_WINDOW` episodes, the returns also as dots), as PNG bytes."""
    import matplotlib

    matplotlib.use("Agg")  # files only, no display
    import matplotlib.pyplot as plt

    steps = np.array([float(row["steps"]) for row in rows])
    returns = np.array([float(row["return"]) for row in rows])
    success = np.array([float(row["success"]) for row in rows])
    window = min(CURVE_WINDOW, max(1, len(rows)))
    figure, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    top.plot(steps, returns, ".", alpha=0.3, color="tab:blue")
    top.plot(steps, moving_average(returns, window), color="tab:blue")
    top.set_ylabel("episode return")
    bottom.plot(steps, moving_average(success, window), color="tab:green")
    bottom.set_ylim(-0.05, 1.05)
    bottom.set_ylabel(f"success rate ({window} episodes)")
    bottom.set_xlabel("env steps")
    figure.tight_layout()
    png = figure_png(figure, dpi=100)
    plt.close(figure)
    return png
