"""The replayed search of the log diagnosis (:mod:`cell.logs.diagnosis`): Gauss-Newton on
world causes' magnitudes, each step confirmed by replaying the batch, a line search along the
fit, and the replays of each log left out (the second look for the causes a first fit hid:
:mod:`cell.logs.second_look`).

A fit is a dict: ``magnitudes`` (cause -> magnitude), ``simulated`` (the batch's replayed
vector there), ``offsets`` (the sensors' offsets fitted on it, closed form), ``left`` (what is
left of the logged vector, N) and, once a Gauss-Newton step was replayed, ``jacobian`` (the
causes' signatures at the fit, Broyden-updated).
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from cell.logs.causes import CAUSES, SENSOR_OFFSET, bounded, magnitudes_json
from cell.logs.fit import Rows, broyden, rmse_n, signature, solve
from cell.logs.nudges import nudged, nudges
from cell.logs.replays import Replayer

#: The line search's factor on the fitted magnitudes (:func:`stretch`) and its most replays
#: (each search's).
STRETCH = 1.3
STRETCH_REPLAYS = 3
OFFSET = SENSOR_OFFSET + ":"
#: The fall of the logs' count misfits' sum of squares (noise widths squared) at which the
#: screening replays a cause at its outcome locator: one parameter's likelihood ratio at 95 %.
COUNT_EVIDENCE = 3.84

Fit = dict[str, Any]


def fixed(blocks: dict[str, np.ndarray]) -> frozenset[str]:
    """The offsets among ``blocks``: fitted at rest, taken whole."""
    return frozenset(name for name in blocks if name.startswith(OFFSET))


def screening_worlds(names: list[str], at: dict[str, float], wide: bool = False
                     ) -> list[dict[str, float]]:
    """The worlds that screen each of ``names`` (not in ``at``) beside the magnitudes ``at``:
    one per probe of its (:meth:`~cell.logs.causes.cause.LogCause.probes`; ``wide``: the far
    ones too, so that a big change is screened near its size, not only by a small step's
    slope)."""
    return [{**at, c: probe} for c in names for probe in CAUSES[c].probes(wide)]


def signatures(residual: np.ndarray, reference: np.ndarray, names: list[str],
               replayed: list[np.ndarray | None], wide: bool = False,
               located: dict[str, tuple[float, np.ndarray]] | None = None
               ) -> dict[str, np.ndarray]:
    """Each of ``names``' signature (:func:`signature` on ``residual``) from the replays of
    its :func:`screening_worlds` (``wide`` as there) and of ``located`` (a cause's further
    magnitude and replay, :func:`located_sides`), their changes taken against the
    ``reference`` replay; a cause whose replays all blew up has none."""
    blocks: dict[str, np.ndarray] = {}
    start = 0
    for c in names:
        probes = CAUSES[c].probes(wide)
        sides = [(probe, None if vector is None else vector - reference)
                 for probe, vector in zip(probes, replayed[start:start + len(probes)],
                                          strict=True)]
        if located and c in located:
            sides.append((located[c][0], located[c][1] - reference))
        start += len(probes)
        column = signature(residual, sides)
        if column is not None:
            blocks[c] = column
    return blocks


def outcome_locators(base: np.ndarray, names: list[str], replayed: list[np.ndarray | None],
                     counts: np.ndarray, wide: bool = True, min_fall: float = 0.0
                     ) -> dict[str, float]:
    """Where each of ``names`` brings the logs' outcome closest: the magnitude between its
    screening probes (:func:`screening_worlds`, ``wide`` as there; ``base`` at 0) where the
    replays' count misfits (the entries ``counts``), taken linear between neighbouring
    probes, are least in sum of squares; a cause whose least is at 0 has none. A tearing
    threshold or a binding's stiffness moves the counts smoothly and steadily, where the
    forces' error has plateaus (tears that come in a burst, a pull that loses its grip) that a
    slope taken at the screening steps stops on: this is the global step before the fit. Only
    the causes whose least falls below the lab's world's by ``min_fall`` are given."""
    out: dict[str, float] = {}
    start, at_zero = 0, float(base[counts] @ base[counts])
    for c in names:
        probes = CAUSES[c].probes(wide)
        points = sorted([(0.0, base), *[(p, v) for p, v in zip(
            probes, replayed[start:start + len(probes)], strict=True) if v is not None]],
            key=lambda point: point[0])
        start += len(probes)
        best, best_cost = 0.0, at_zero
        for (a, low), (b, high) in itertools.pairwise(points):
            e0, de = low[counts], high[counts] - low[counts]
            t = float(np.clip(-(e0 @ de) / (de @ de), 0.0, 1.0)) if de @ de > 0.0 else 0.0
            cost = float((e0 + t * de) @ (e0 + t * de))
            if cost < best_cost:
                best, best_cost = a + t * (b - a), cost
        if best != 0.0 and at_zero - best_cost >= min_fall:
            out[c] = best
    return out


def located_sides(replayer: Replayer, base: np.ndarray, names: list[str],
                  replayed: list[np.ndarray | None], counts: np.ndarray
                  ) -> dict[str, tuple[float, np.ndarray]]:
    """The causes whose outcome locator (:func:`outcome_locators` on the wide screening)
    brings the logs' counts closer than the lab's world by :data:`COUNT_EVIDENCE`, each
    replayed there: its magnitude and replay, a further side of its signature. A tearing
    threshold's forces answer in a narrow valley (past it the tears come in a burst): both
    screening steps can overshoot it and read worse than the lab's world, where the counts
    say how far to go."""
    sharp = outcome_locators(base, names, replayed, counts,
                             min_fall=COUNT_EVIDENCE * replayer.weight ** 2)
    vectors = replayer.batches([{c: m} for c, m in sharp.items()]) if sharp else []
    return {c: (m, vector) for (c, m), vector in zip(sharp.items(), vectors, strict=True)
            if vector is not None}


def replayed_fit(measured: np.ndarray, simulated: np.ndarray, magnitudes: dict[str, float],
                 offsets: dict[str, np.ndarray]) -> Fit:
    """The fit of a replayed world: its sensors' offsets and what is left."""
    fitted, left = solve(measured - simulated, offsets, None, fixed(offsets))
    return {"magnitudes": magnitudes, "simulated": simulated, "left": left, "offsets": fitted}


def dropped(world: list[str], fit: Fit, left: np.ndarray, without_left: np.ndarray
            ) -> dict[str, Any]:
    """The report of ``world``'s causes, fitted at ``fit``, not named: them, their
    magnitudes, and the held-out error with them (``left``) and without (``without_left``),
    N."""
    return {"causes": world, "params": magnitudes_json(fit["magnitudes"]),
            "heldout_rmse_N": rmse_n(left), "without_N": rmse_n(without_left)}


def gauss_newton(replayer: Replayer, measured: np.ndarray, offsets: dict[str, np.ndarray],
                 start: Fit, world: list[str], jacobian: np.ndarray, steps: int,
                 stretched: bool = True) -> Fit:
    """Gauss-Newton on ``world``'s magnitudes from ``start`` (a cause it lacks at 0), with
    ``jacobian``'s columns as their signatures there, each step replayed, then (where
    ``stretched``) :func:`stretch`: the best replayed fit, ``start`` itself where none beats
    it."""
    (best,) = newton_side_by_side(replayer, measured, offsets, [(start, world, jacobian)],
                                  steps)
    if best is start or not stretched:
        return best
    return stretch(replayer, measured, offsets, world, best)


def newton_side_by_side(replayer: Replayer, measured: np.ndarray,
                        offsets: dict[str, np.ndarray],
                        starts: list[tuple[Fit, list[str], np.ndarray]], steps: int
                        ) -> list[Fit]:
    """:func:`gauss_newton`'s steps (no line search) on each of ``starts`` (a start, its
    causes, their signatures there), the worlds of each step replayed side by side in one
    batch: the best replayed fit of each, its start where none beats it. A step waits for
    the slowest of its replays, so fits that do not wait on each other share the wait."""
    best = [start for start, _, _ in starts]
    magnitudes = [np.array([start["magnitudes"].get(c, 0.0) for c in world])
                  for start, world, _ in starts]
    simulated = [start["simulated"] for start, _, _ in starts]
    jacobians = [jacobian for _, _, jacobian in starts]
    going = list(range(len(starts)))
    for _ in range(steps + 1):
        targets = {}
        for k in going:
            fitted, _ = solve(measured - simulated[k], {"world": jacobians[k], **offsets},
                              None, fixed(offsets))
            targets[k] = bounded(starts[k][1], magnitudes[k] + fitted["world"])
        worlds = [dict(zip(starts[k][1], targets[k].tolist(), strict=True)) for k in going]
        replayed = replayer.batches(worlds)
        for k, at, vector in zip(list(going), worlds, replayed, strict=True):
            if vector is None:
                going.remove(k)
                continue
            jacobians[k] = broyden(jacobians[k], targets[k] - magnitudes[k],
                                   vector - simulated[k])
            magnitudes[k], simulated[k] = targets[k], vector
            trial = replayed_fit(measured, vector, at, offsets)
            if rmse_n(trial["left"]) < rmse_n(best[k]["left"]):
                best[k] = {**trial, "jacobian": jacobians[k]}
    return best


def mirrored(replayer: Replayer, measured: np.ndarray, offsets: dict[str, np.ndarray],
             fit: Fit, world: list[str], steps: int) -> Fit:
    """``fit`` with each of ``world``'s angles (:attr:`~cell.logs.causes.cause.LogCause.kind`
    ``"angle"``) turned the other way where that replays closer, then Gauss-Newton from there
    (its signature's sign turned with it). A fibre turned either way stiffens a pull across
    it nearly alike, so the fit can settle on the side it started from; only the small uneven
    part tells the sides apart, and one replay of the mirror reads it."""
    if "jacobian" not in fit:
        return fit
    for k, c in enumerate(world):
        magnitude = fit["magnitudes"].get(c, 0.0)
        if CAUSES[c].kind != "angle" or magnitude == 0.0:
            continue
        at = {**fit["magnitudes"], c: -magnitude}
        (replayed,) = replayer.batches([at])
        if replayed is None:
            continue
        trial = replayed_fit(measured, replayed, at, offsets)
        if rmse_n(trial["left"]) < rmse_n(fit["left"]):
            jacobian = fit["jacobian"].copy()
            jacobian[:, k] *= -1.0
            fit = gauss_newton(replayer, measured, offsets, {**trial, "jacobian": jacobian},
                               world, jacobian, steps)
    return fit


def from_probes(replayer: Replayer, measured: np.ndarray, offsets: dict[str, np.ndarray],
                fit: Fit, world: list[str], jacobian: np.ndarray, steps: int) -> Fit:
    """``fit``, or where a world the screening replayed for one of ``world``'s causes (that
    cause at a probe, the others at 0: :func:`screening_worlds`, wide) fits the logs closer,
    Gauss-Newton again from the closest such world, the better of the two kept. A cause whose
    effect is nearly even about the lab's world (a fibre turned either way) gives the fit no
    slope there, and a cause beside it takes the step; the screening's replay near the
    cause's size is a replay done already, and a fit must not end farther than it. The
    screening's signatures (``jacobian``) are secants through those replays, so they start
    the fit there (:func:`gauss_newton` keeps its start where no step beats it)."""
    worlds = screening_worlds(world, {}, wide=True)
    best = fit
    for at, replayed in zip(worlds, replayer.batches(worlds), strict=True):
        if replayed is None:
            continue
        trial = replayed_fit(measured, replayed, at, offsets)
        if rmse_n(trial["left"]) < rmse_n(best["left"]):
            best = {**trial, "jacobian": jacobian}
    if best is fit:
        return fit
    return gauss_newton(replayer, measured, offsets, best, world, jacobian, steps)


def pruned(replayer: Replayer, measured: np.ndarray, offsets: dict[str, np.ndarray],
           fit: Fit, world: list[str], min_gain: float, steps: int) -> tuple[Fit, list[str]]:
    """``fit`` and ``world`` less each cause that does not earn its place in the replays
    (backward elimination): of two or more causes, each is taken out in turn, the others
    fitted again without it from where ``fit`` holds them (:func:`newton_side_by_side`), and
    of those whose refit's error comes within ``min_gain`` of ``fit``'s, the one whose refit
    is closest goes (:func:`stretch` then runs on it); then again, one at a time. What went
    is listed under the fit's ``pruned``. The selection is linearised at the lab's world,
    where a cause beside the one the logs show can take a share of its effect, and a replayed
    fit can then end where the two make up for each other (a fibre turned short of the truth
    beside a muscle a little stiffer); the bar is the one every cause meets to be named.
    Taken out without a refit, a cause that makes up for another fitted short looks needed
    most, and where either of two causes could go (stiffer bindings and a higher tearing
    threshold both carry more load), the world that fits closer without the other stays."""
    gone, replayer.round = [], "pruning"
    while len(world) > 1 and "jacobian" in fit:
        worlds = [{c: m for c, m in fit["magnitudes"].items() if c != cause} for cause in world]
        starts = [(k, replayed_fit(measured, replayed, at, offsets)) for k, (at, replayed)
                  in enumerate(zip(worlds, replayer.batches(worlds), strict=True))
                  if replayed is not None]
        rests = {k: np.delete(fit["jacobian"], k, axis=1) for k, _ in starts}
        trials = [({**trial, "jacobian": rests[k]}, world[:k] + world[k + 1:], rests[k])
                  for k, trial in starts]
        refits = newton_side_by_side(replayer, measured, offsets, trials, steps)
        going = [(rmse_n(refit["left"]), k, refit) for (k, _), refit
                 in zip(starts, refits, strict=True)
                 if (1.0 - min_gain) * rmse_n(refit["left"]) <= rmse_n(fit["left"])]
        if not going:
            break
        _, k, refit = min(going, key=lambda item: item[0])
        rest = world[:k] + world[k + 1:]
        refit = stretch(replayer, measured, offsets, rest, refit)
        gone.append({"cause": world[k], **CAUSES[world[k]].to_json(fit["magnitudes"][world[k]]),
                     "rmse_N": rmse_n(refit["left"]), "with_rmse_N": rmse_n(fit["left"])})
        fit, world = refit, rest
    return ({**fit, "pruned": gone} if gone else fit), world


def stretch(replayer: Replayer, measured: np.ndarray, offsets: dict[str, np.ndarray],
            world: list[str], best: Fit) -> Fit:
    """A line search along the lab's world to the best fit (:func:`_line_search` on every
    magnitude at once), then, where the world has more than one cause, on each cause's
    magnitude alone: a cause's response flattens as it grows (a turned fibre, a stiffer
    muscle), so signatures taken at the screening step and Gauss-Newton on them stop short
    of a strong cause, and causes beside one another stop short by different shares."""
    best = _line_search(replayer, measured, offsets, world, best, np.ones(len(world), bool))
    if len(world) > 1:
        for alone in np.eye(len(world), dtype=bool):
            best = _line_search(replayer, measured, offsets, world, best, alone)
    return best


def _line_search(replayer: Replayer, measured: np.ndarray, offsets: dict[str, np.ndarray],
                 world: list[str], best: Fit, scaled: np.ndarray) -> Fit:
    """The magnitudes of ``best`` where ``scaled`` is true times :data:`STRETCH` while that
    lowers the replayed error, or once by its inverse where the first stretch does not; the
    signatures follow each better point (Broyden)."""
    start = np.array([best["magnitudes"][c] for c in world])
    scale, factor = 1.0, STRETCH
    for _ in range(STRETCH_REPLAYS):
        trial = bounded(world, np.where(scaled, start * scale * factor, start))
        at = dict(zip(world, trial.tolist(), strict=True))
        (replayed,) = replayer.batches([at])
        better = False
        if replayed is not None:
            moved = replayed_fit(measured, replayed, at, offsets)
            if rmse_n(moved["left"]) < rmse_n(best["left"]):
                previous = np.array([best["magnitudes"][c] for c in world])
                moved["jacobian"] = broyden(best["jacobian"], trial - previous,
                                            replayed - best["simulated"])
                best, scale, better = moved, scale * factor, True
        if not better:
            if factor < 1.0 or scale != 1.0:
                break
            factor = 1.0 / STRETCH
    return best


def heldout_replays(replayer: Replayer, measured: np.ndarray, rows: Rows, fit: Fit,
                    world: list[str], offsets: dict[str, np.ndarray], without: Fit,
                    without_left: np.ndarray, min_heldout_gain: float, names: list[str]
                    ) -> np.ndarray:
    """Each log's residual in the world of ``world``'s causes fitted on the other logs (a
    Gauss-Newton step from the batch's fit on their rows), replayed; or, where the batch's
    fit does not beat ``without`` (the world without those causes) on the other logs by
    ``min_heldout_gain``, the log's residual in that world held out (``without_left``). A
    change that only the log left out asks for (one tear the replay happens to miss) is
    where the others leave it, not where the step from a fit that log made keeps it.

    Each fold's world is also replayed nudged in ``names`` as the spread check nudges
    (:func:`~cell.logs.nudges.nudges`; none where ``names`` is empty), and the log's residual
    is that of the replay whose error is the median: one replay is one draw of the tears'
    chaos (a fold a ten-thousandth of a radian from the batch's fit can replay its log ten
    times farther)."""
    replayer.round = "held out"
    residual = measured - fit["simulated"]
    left = without_left.copy()
    shifts = nudges(names) if names else [{}]
    jobs, fits = [], []
    for i in range(len(replayer.folders)):
        others = rows.log != i
        if rmse_n(fit["left"][others]) > (1.0 - min_heldout_gain) * rmse_n(
                without["left"][others]):
            continue
        fitted, _ = solve(residual, {"world": fit["jacobian"], **offsets}, others,
                          fixed(offsets))
        moved = bounded(world, np.array([fit["magnitudes"][c] for c in world])
                        + fitted["world"])
        at = dict(zip(world, moved.tolist(), strict=True))
        jobs += [(i, nudged(at, shift)) for shift in shifts]
        fits.append((i, fitted))
    replayed = replayer.run(jobs) if jobs else []
    for k, (i, fitted) in enumerate(fits):
        mine = rows.log == i
        correction = sum((offsets[c] @ fitted[c] for c in offsets), np.zeros(measured.size))
        draws = [measured[mine] - vector - correction[mine]
                 for vector in replayed[k * len(shifts):(k + 1) * len(shifts)]
                 if vector is not None] or [measured[mine] - fit["simulated"][mine]
                                            - correction[mine]]
        errors = [rmse_n(draw) for draw in draws]
        left[mine] = draws[int(np.argsort(errors)[len(errors) // 2])]
    return left
