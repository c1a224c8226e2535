"""Measured force curves (force against time), read from CSV, for the force release rule.

The file has a header line and at least the columns ``time_s`` and ``force_n``; comment lines
start with ``#``; extra columns are ignored. Times must increase.

Example:
    >>> curve = ForceCurve.from_csv("assets/cutting_force/boning_knife_synthetic.csv")
    >>> curve.at(1.5)
    10.587
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cell.errors import InputError


@dataclass(frozen=True, eq=False)
class ForceCurve:
    """A force history: ``force_n`` (N) at ``time_s`` (s), linearly interpolated and held
    constant outside the measured span."""

    time_s: np.ndarray
    force_n: np.ndarray

    def at(self, time_s: float) -> float:
        """Force at ``time_s``, N."""
        return float(np.interp(time_s, self.time_s, self.force_n))

    @classmethod
    def from_csv(cls, path: str | Path) -> ForceCurve:
        """Read and validate a curve; errors name the file, line and column."""
        path = Path(path)
        try:
            text = path.read_text()
        except OSError as exc:
            raise InputError(path, None, f"cannot read: {exc.strerror}") from None
        lines = [(n, line) for n, line in enumerate(text.splitlines(), start=1)
                 if line.strip() and not line.lstrip().startswith("#")]
        if not lines:
            raise InputError(path, None, "no header line")
        header_line, header = lines[0]
        columns = next(csv.reader([header]))
        for name in ("time_s", "force_n"):
            if name not in columns:
                raise InputError(path, f"line {header_line}, column {name}", "missing column")
        index = {name: columns.index(name) for name in ("time_s", "force_n")}
        values: dict[str, list[float]] = {"time_s": [], "force_n": []}
        for number, row in zip((n for n, _ in lines[1:]),
                               csv.reader(line for _, line in lines[1:]), strict=True):
            for name, col in index.items():
                where = f"line {number}, column {name}"
                try:
                    value = float(row[col])
                except (IndexError, ValueError):
                    raise InputError(path, where, "not a number") from None
                if not math.isfinite(value):
                    raise InputError(path, where, f"not finite: {value}")
                if name == "time_s" and values["time_s"] and value <= values["time_s"][-1]:
                    raise InputError(path, where, "time must increase")
                values[name].append(value)
        if len(values["time_s"]) < 2:
            raise InputError(path, None, "needs at least 2 samples")
        return cls(np.array(values["time_s"]), np.array(values["force_n"]))
