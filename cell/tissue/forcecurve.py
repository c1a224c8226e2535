"""Measured force curves (force against time), read from CSV, for the force release rule.

The file has a header line and at least the columns ``time_s`` and ``force_n``; comment lines
start with ``#``; extra columns are ignored. Times must increase.

Example:
    >>> curve = ForceCurve.from_csv("assets/cutting_force/boning_knife_synthetic.csv")
    >>> round(curve.at(1.5), 3)
    10.587
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cell.config import FORCE_N, TIME_S
from cell.errors import InputError
from cell.io import read_csv


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
        """Read and validate a curve (:func:`cell.io.read_csv`).

        Raises:
            InputError: naming the file, and the line and column where it applies: a missing
                column, a cell that is not a finite number or not plausible
                (:data:`cell.config.FORCE_N`, :data:`cell.config.TIME_S`), a time that does
                not increase, fewer than 2 samples.
        """
        table = read_csv(path, ("time_s", "force_n"))
        time = table.numbers("time_s", TIME_S.refusal)
        force = table.numbers("force_n", FORCE_N.refusal)
        still = np.flatnonzero(np.diff(time) <= 0)
        if still.size:
            raise InputError(table.path, table.where(int(still[0]) + 1, "time_s"),
                             "time must increase")
        if len(time) < 2:
            raise InputError(table.path, None, "needs at least 2 samples")
        return cls(time, force)
