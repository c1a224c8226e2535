"""The replays' spread in the log diagnosis (:mod:`cell.logs.diagnosis`): a world judged by
the error its replays give, not by the one its own replay happens to give.

A separation is close to chaotic: which binding tears first, and when, turns on a hair, and
with it the force after the tear. Nudged by 1 % in every cause, the lab's own world replays an
unchanged batch 0.25 to 0.72 N away from its logs; a fit that searches a hundred replays
finds one whose tears happen to line up (a blade friction 4 % lower halved that error, and
its nudged replays were no closer than the lab's). So before a world's causes are named, the
named world and the lab's are each replayed nudged (:data:`~cell.logs.nudges.JITTERS`
times, every cause screened by :data:`~cell.logs.nudges.JITTER` one way or the other, the
same nudges for both) and compared by the median of their errors, on the bar every cause
meets; with two causes or more, each must also beat the world without it on those terms.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np

from cell.logs.causes import CAUSES
from cell.logs.fit import Rows, rmse_n
from cell.logs.nudges import JITTER, JITTERS, nudged, nudges
from cell.logs.replays import Replayer
from cell.logs.search import Fit, dropped, heldout_replays, replayed_fit


def nudged_replays(replayer: Replayer, worlds: list[dict[str, float]], names: list[str]
                   ) -> list[list[np.ndarray]]:
    """Each of ``worlds``' own replay and its nudged ones
    (:func:`~cell.logs.nudges.nudges` of ``names``), less those that blew up."""
    shifts = nudges(names)
    replayed = replayer.batches([nudged(w, s) for w in worlds for s in shifts])
    return [[v for v in replayed[k * len(shifts):(k + 1) * len(shifts)] if v is not None]
            for k in range(len(worlds))]


def spread_errors(replayer: Replayer, measured: np.ndarray, offsets: dict[str, np.ndarray],
                  worlds: list[dict[str, float]], names: list[str]) -> list[float]:
    """The median RMSE (N) of each of ``worlds`` over its own replay and its nudged ones
    (:func:`nudged_replays`), the sensors' offsets fitted on each; a replay that blew up does
    not count (every one of a world blowing up: inf)."""
    return [_median_error(measured, offsets, world, vectors) for world, vectors
            in zip(worlds, nudged_replays(replayer, worlds, names), strict=True)]


def _median_error(measured: np.ndarray, offsets: dict[str, np.ndarray],
                  world: dict[str, float], vectors: list[np.ndarray]) -> float:
    """The median RMSE (N) of ``world``'s replays ``vectors``, the sensors' offsets fitted on
    each (inf where there are none)."""
    errors = [rmse_n(replayed_fit(measured, v, world, offsets)["left"]) for v in vectors]
    return float(np.median(errors)) if errors else float("inf")


def replay_scatter(replayer: Replayer, measured: np.ndarray, offsets: dict[str, np.ndarray],
                   magnitudes: dict[str, float], names: list[str]) -> dict[str, float]:
    """How close the world of ``magnitudes`` comes to the logs against how far its own
    replays scatter: the median RMSE of its replays (as :func:`spread_errors`), the median
    distance between two of them (RMS, N; 0 where fewer than two stayed finite), the logs'
    sensor noise in the same terms (:attr:`~cell.logs.replays.Replayer.noise_rmse_n`) and
    the floor of both (``floor_N``, their root sum of squares). Were the world the logs' own,
    a log would be one more such draw with the sensor's noise on it, as far from a replay as
    two replays are from each other and that noise further: an error no larger than the
    floor is all the replays can explain."""
    (vectors,) = nudged_replays(replayer, [magnitudes], names)
    distances = [rmse_n(a - b) for a, b in itertools.combinations(vectors, 2)]
    scatter = float(np.median(distances)) if distances else 0.0
    return {"median_rmse_N": _median_error(measured, offsets, magnitudes, vectors),
            "scatter_N": scatter, "noise_N": replayer.noise_rmse_n,
            "floor_N": math.hypot(scatter, replayer.noise_rmse_n)}


def held_against_spread(replayer: Replayer, measured: np.ndarray,
                        offsets: dict[str, np.ndarray], fit: Fit, world: list[str],
                        names: list[str], min_gain: float) -> tuple[list[str], dict[str, Any]]:
    """The causes of ``world`` (fitted at ``fit``) that hold against the replays' spread
    (module docstring): all of them where the fitted world's median error is ``min_gain`` (a
    share) below the lab's, and, with two or more, less the one whose removal costs least
    where removing it does not raise the median by that share; none where the fitted world
    does not beat the lab's. With the medians found (``spread``, for the report)."""
    replayer.round = "spread"
    magnitudes = {c: fit["magnitudes"][c] for c in world}
    without = [{c: m for c, m in magnitudes.items() if c != cause} for cause in world]
    lab, fitted, *each = spread_errors(replayer, measured, offsets,
                                       [{}, magnitudes, *(without if len(world) > 1 else [])],
                                       names)
    report: dict[str, Any] = {"jitter": JITTER, "replays_each": JITTERS + 1,
                              "lab_median_rmse_N": lab, "median_rmse_N": fitted}
    if fitted > (1.0 - min_gain) * lab:
        return [], {**report, "kept": []}
    kept = list(world)
    if each:
        report["without_median_rmse_N"] = dict(zip(world, each, strict=True))
        k = int(np.argmin(each))
        if fitted > (1.0 - min_gain) * each[k] and each[k] <= (1.0 - min_gain) * lab:
            kept.pop(k)
    return kept, {**report, "kept": kept}


def spread_checked(replayer: Replayer, measured: np.ndarray, rows: Rows, fit: Fit,
                   world: list[str], left: np.ndarray, names: list[str],
                   offsets: dict[str, np.ndarray], start: Fit, without_left: np.ndarray,
                   min_gain: float) -> tuple[Fit, list[str], np.ndarray]:
    """``fit`` of ``world``'s causes (``left``: its held-out residual) less what does not hold
    against the replays' spread (:func:`held_against_spread`, ``names`` nudged): the fit,
    its causes and its held-out residual; the lab's world (``start``, ``without_left``) with
    the causes listed as dropped where none holds, or the rest of the world at its fitted
    magnitudes, its logs left out replayed again, where one cause goes (listed under
    ``pruned``)."""
    kept, report = held_against_spread(replayer, measured, offsets, fit, world, names,
                                       min_gain)
    if kept == world:
        return {**fit, "spread": report}, world, left
    if not kept:
        return ({**start, "confirmed": False, "dropped": dropped(world, fit, left, without_left),
                 "spread": report}, [], without_left)
    at = {c: fit["magnitudes"][c] for c in kept}
    (replayed,) = replayer.batches([at])
    if replayed is None:
        return {**fit, "spread": report}, world, left
    (gone,) = [c for c in world if c not in kept]
    rest = {**replayed_fit(measured, replayed, at, offsets), "confirmed": True,
            "jacobian": fit["jacobian"][:, [world.index(c) for c in kept]], "spread": report,
            "pruned": [*fit.get("pruned", []), {"cause": gone, **CAUSES[gone].to_json(
                fit["magnitudes"][gone]), "rmse_N": report["without_median_rmse_N"][gone],
                "with_rmse_N": report["median_rmse_N"], "by": "spread"}]}
    return rest, kept, heldout_replays(replayer, measured, rows, rest, kept, offsets, start,
                                       without_left, min_gain, names)
