"""The runs of a sweep: which values of the swept variables each run takes, and its seed.

The design depends on the sweep file alone (its sampling, variables and seed), never on the
machine or the worker that plays a run, so that re-running a sweep finds the same runs.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.stats import qmc

from cell.scale.spec import Range, SweepSpec


@dataclass(frozen=True)
class RunPoint:
    """One run of a sweep: its ``index`` (from 0), its ``seed`` (the sweep's seed plus the
    index) and the swept ``values`` by dotted key, in each key's own unit.

    Example:
        >>> RunPoint(3, 3, {"cut.speed_m_s": 0.04}).name
        'run-0003'
    """

    index: int
    seed: int
    values: dict[str, Any]

    @property
    def name(self) -> str:
        """The run's name in the results folder."""
        return f"run-{self.index:04d}"

    def to_json(self) -> dict[str, Any]:
        """Index, seed and values, as the results folder stores them."""
        return {"run": self.index, "seed": self.seed, "values": self.values}


def design(spec: SweepSpec) -> list[RunPoint]:
    """The sweep's runs: every combination of the listed values (grid, the first variable
    varying slowest), or ``runs`` draws (random: independent uniform; latin-hypercube: one
    in each of ``runs`` equal strata of every range), seeded by the sweep's seed.

    Example:
        >>> from pathlib import Path
        >>> from cell.scale.spec import SweepHead
        >>> spec = SweepSpec(Path("s.toml"), SweepHead(scenario="d.toml", seed=10),
        ...                  variables={"a": (1, 2), "b": (0.1, 0.2)})
        >>> [(p.seed, p.values["a"], p.values["b"]) for p in design(spec)]
        [(10, 1, 0.1), (11, 1, 0.2), (12, 2, 0.1), (13, 2, 0.2)]
    """
    keys = list(spec.variables)
    head = spec.head
    if head.sampling == "grid":
        combos = list(itertools.product(*(spec.variables[k] for k in keys)))
    else:
        ranges = [spec.variables[k] for k in keys]
        rng = np.random.default_rng(head.seed)
        if head.sampling == "random":
            unit = rng.random((head.runs, len(keys)))
        else:
            unit = qmc.LatinHypercube(d=len(keys), rng=rng).random(head.runs)
        combos = [tuple(_scaled(float(u), r) for u, r in zip(row, ranges, strict=True))
                  for row in unit]
    return [RunPoint(i, head.seed + i, dict(zip(keys, combo, strict=True)))
            for i, combo in enumerate(combos)]


def _scaled(unit: float, bounds: Range) -> float:
    """``unit`` in [0, 1) mapped onto ``bounds`` (log-uniformly for a log range)."""
    if bounds.log:
        return float(np.exp(np.log(bounds.low) + unit * np.log(bounds.high / bounds.low)))
    return bounds.low + unit * (bounds.high - bounds.low)
