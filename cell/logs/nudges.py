"""The nudges of the log diagnosis (:mod:`cell.logs.diagnosis`): a world replayed with every
screened cause moved by :data:`JITTER` one way or the other, so that its replays show the
tears' chaos (:mod:`cell.logs.spread`, :mod:`cell.logs.chaos`) and a world is judged by the
median of its replays, not by one draw.

Example:
    >>> [sorted(n) for n in nudges(["tissue_stiffness"], count=2)]
    [[], ['tissue_stiffness'], ['tissue_stiffness']]
"""

from __future__ import annotations

import numpy as np

from cell.logs.causes import bounded

#: Each screened cause's nudge (a factor's logarithm, or an angle in rad): far inside the
#: 25 % the diagnosis resolves, far above what a replay reproduces exactly.
JITTER = 0.01
#: Nudged replays of a world, besides its own.
JITTERS = 4


def nudges(names: list[str], count: int = JITTERS) -> list[dict[str, float]]:
    """``count`` nudges of ``names`` (each cause :data:`JITTER` one way or the other, drawn
    once for all: the same seed, the same nudges), after the world's own (no nudge)."""
    signs = [np.random.default_rng([k, len(names)]).choice([-1.0, 1.0], len(names))
             for k in range(count)]
    return [{}] + [dict(zip(names, (JITTER * s).tolist(), strict=True)) for s in signs]


def nudged(world: dict[str, float], nudge: dict[str, float]) -> dict[str, float]:
    """``world``'s magnitudes with ``nudge`` added (a cause of either alone kept), within
    each cause's bounds (:func:`~cell.logs.causes.bounded`)."""
    names = list({**world, **nudge})
    moved = bounded(names, np.array([world.get(c, 0.0) + nudge.get(c, 0.0) for c in names]))
    return dict(zip(names, moved.tolist(), strict=True))
