"""Whether a hidden change shows in its logs at all (the log bench's ``visible``,
docs/logs.md): a change the logs do not show is no diagnosis's miss.

A separation is close to chaotic (:mod:`cell.logs.spread`): one replay is one draw of which
binding tears when, so each world is judged by its replays nudged as the diagnosis's spread
check nudges them, and a change shows where its world's replays come nearer the logs than
those of the world without it by the share the diagnosis asks a cause to earn, on the median:
the bar of the spread check, so that a change shown is one a diagnosis held to that bar could
name. How far the two worlds' draws separate is given beside (a one-sided Mann-Whitney
p-value): with five draws a world, a median lower by chance is common where the tears
scatter, and a p-value below 0.05 takes nearly every draw of one world under every draw of
the other.

Where a diagnosis named another world than the truth, that world is judged the same way: a
miss whose named world the logs do not put behind the true one by that share is a world the
logs cannot tell from the truth (two changes one stands in for), not a search that stopped
short of a better fit.

Example:
    >>> shown([0.30, 0.31, 0.32, 0.33, 0.34], [0.40, 0.41, 0.42, 0.43, 0.44], 0.08)[0]
    True
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from cell.cores import default_workers

if TYPE_CHECKING:
    from cell.logs.batch import LogBatch
    from cell.logs.replays import ReplayPool


def visibility(batch: LogBatch, changes: dict[str, float], workers: int | None,
               min_gain: float, cluster: ReplayPool | None = None,
               named: dict[str, float] | None = None) -> dict[str, Any]:
    """Which of the hidden world ``changes`` (cause -> magnitude, as
    :func:`~cell.logs.causes.changed_world` takes them) the batch shows at all: the batch is
    replayed in the lab's world, in the true one and, of two or more changes, in the true one
    less each, every world also nudged as the diagnosis's spread check nudges it
    (:func:`~cell.logs.spread.nudged_replays`), and judged by the median force RMSE of its
    replays: one replay is one draw of the tears' chaos, and the true world's own can land
    far nearer the logs, or farther, than its nudged ones. A change whose removal leaves
    that median within ``min_gain`` of the true world's (for one change alone: the lab's
    world within that share of the true one) is not in these logs, and a diagnosis that asks
    a cause to lower the error by that share cannot name it (a tearing threshold raised where
    nothing tore either way). The replays run as the diagnosis's do (``workers``,
    ``cluster``). ``named``, a world a diagnosis named in place of ``changes`` (as they are
    given), is replayed the same way (the lab's world where it is empty). Returns ``visible``
    (cause -> bool, :func:`shown`) with each change's ``p_value``, the medians of the lab's
    and the true world, N, the replays it took, and for ``named`` its median
    (``named_rmse_N``) and whether the logs put the true world ahead of it by ``min_gain``
    (``truth_preferred``, :func:`shown`, with ``truth_preferred_p``); None without it."""
    from cell.logs.causes import applicable
    from cell.logs.fit import logged_vector, rmse_n
    from cell.logs.outcome import EVIDENCE_ROWS
    from cell.logs.replays import Replayer
    from cell.logs.spread import nudged_replays

    unjudged = {"named_rmse_N": None, "truth_preferred": None, "truth_preferred_p": None}
    if not changes:
        return {"visible": {}, "lab_rmse_N": None, "truth_rmse_N": None, "p_value": {},
                "replays": 0, **unjudged}
    measured, rows = logged_vector(batch.logs, EVIDENCE_ROWS)
    less = [{k: v for k, v in changes.items() if k != c} for c in changes] if len(changes) > 1 \
        else []
    other = [named] if named else []
    worlds = [{}, dict(changes), *less, *other]
    with Replayer(batch, workers or default_workers(len(batch.logs)), cluster) as replayer:
        replayed = nudged_replays(replayer, worlds, list(applicable(batch.scenarios[0])))
        replays = replayer.count
    errors = [[rmse_n((measured - v)[rows.force]) for v in vectors] for vectors in replayed]
    without = errors[2:2 + len(less)] if less else errors[:1]
    judged = unjudged
    if named is not None:
        rival = errors[-1] if other else errors[0]
        preferred, p_named = shown(errors[1], rival, min_gain)
        judged = {"named_rmse_N": _median(rival), "truth_preferred": preferred,
                  "truth_preferred_p": p_named}
    verdicts = {c: shown(errors[1], error, min_gain)
                for c, error in zip(changes, without, strict=True)}
    return {"visible": {c: bool(seen) for c, (seen, _) in verdicts.items()},
            "p_value": {c: p for c, (_, p) in verdicts.items()},
            "lab_rmse_N": _median(errors[0]), "truth_rmse_N": _median(errors[1]),
            "replays": replays, **judged}


def shown(truth: Sequence[float], without: Sequence[float], min_gain: float
          ) -> tuple[bool, float]:
    """Whether a change shows in its logs: the median of the force RMSEs (N) of the true
    world's nudged replays ``truth`` ``min_gain`` (a share) under that of the world without
    the change ``without`` (module docstring); with the one-sided Mann-Whitney p-value of
    ``truth`` under ``without`` (1 where either world has no replay).

    Example:
        >>> shown([0.30, 0.31, 0.32, 0.33, 0.34], [0.40, 0.41, 0.42, 0.43, 0.44], 0.08)
        (True, 0.004)
        >>> shown([0.41, 0.42, 0.43, 0.44, 0.45], [0.40, 0.41, 0.42, 0.43, 0.44], 0.08)[0]
        False
    """
    from scipy.stats import mannwhitneyu

    if not truth or not without:
        return False, 1.0
    p = float(mannwhitneyu(truth, without, alternative="less").pvalue)
    return bool(_median(truth) <= (1.0 - min_gain) * _median(without)), p


def _median(errors: Sequence[float]) -> float:
    """The median of ``errors`` (inf where there are none: every replay blew up)."""
    return float(np.median(errors)) if errors else math.inf
