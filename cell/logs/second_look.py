"""The second look of the log diagnosis (:mod:`cell.logs.diagnosis`): once a first fit
stands, the causes it hid. A cause may show only beside another (a binding's tearing under
stiffer muscles, a gradient under a stronger seam): every other cause is screened again in the
fitted world, selected on what the fit leaves, fitted with the first causes, and kept on the
first fit's terms, held out as well.
"""

from __future__ import annotations

import math

import numpy as np

from cell.diagnosis.engine.determined import determined
from cell.logs.fit import Rows, Step, forward_selection, rmse_n, scored_step, solve
from cell.logs.replays import Replayer
from cell.logs.search import (
    Fit,
    bounded,
    fixed,
    gauss_newton,
    heldout_replays,
    pruned,
    replayed_fit,
    screening_worlds,
    signatures,
)
from cell.logs.spread import replay_scatter


def confirmed_second_look(replayer: Replayer, measured: np.ndarray, rows: Rows, fit: Fit,
                          world: list[str], left: np.ndarray, names: list[str],
                          offsets: dict[str, np.ndarray], min_gain: float, steps: int
                          ) -> tuple[Fit, np.ndarray, list[str], list[Step]]:
    """:func:`second_look` on a confirmed fit of ``world``'s causes (``left``: its held-out
    residual; ``names``: the causes screened): the fit, its held-out
    residual, its causes and the steps of those the second look adds, kept only where its
    replays lower the error of the logs fitted and of each log left out by ``min_gain`` (a
    share) against ``fit``'s; else ``fit``, saying what was tried (``second_look``). Before
    the logs left out are replayed, the causes added must beat the first fit's refitted
    without them (:func:`earn_their_place`), then every cause of the larger world must earn
    its place again (:func:`~cell.logs.search.pruned`): the second look may add a small cause
    beside the one it finds, or find the one a first cause stood in for. Where the causes the
    signatures select do not stand, the replays are read for another (the signatures are
    linear, the replays are what the logs are compared with)."""
    replayer.round = "second look"
    magnitudes = {c: fit["magnitudes"][c] for c in world}
    scatter = replay_scatter(replayer, measured, offsets, magnitudes, names)
    # Nothing is left to find where the fit is as close as the true world's own replays
    # would be: no cause could lower the error by the gain asked.
    scatter["looked"] = (1.0 - min_gain) * scatter["median_rmse_N"] > scatter["floor_N"]
    fit = {**fit, "replay_scatter": scatter}
    if not scatter["looked"]:
        return fit, left, world, []
    tried: list[dict[str, object]] = []
    excluded: tuple[str, ...] = ()
    while True:
        selected, moved, selection = second_look(replayer, measured, rows, fit, world, names,
                                                 offsets, min_gain, steps, excluded)
        if not selected:
            break
        kept, attempt = confirmed(replayer, measured, rows, fit, left, world, names, offsets,
                                  min_gain, steps, selected, moved)
        tried.append(attempt)
        if kept is not None:
            moved, moved_left, union = kept
            gone = fit.get("pruned", []) + moved.get("pruned", [])
            return ({**moved, "confirmed": True, "second_look": second_look_record(tried),
                     "replay_scatter": scatter, **({"pruned": gone} if gone else {})},
                    moved_left, union, [step for step in selection[1:] if step.added in union])
        if attempt["shown_by"] != "signatures":
            break
        excluded = tuple(selected)
    if not tried:
        return fit, left, world, []
    return {**fit, "second_look": second_look_record(tried)}, left, world, []


def confirmed(replayer: Replayer, measured: np.ndarray, rows: Rows, fit: Fit, left: np.ndarray,
              world: list[str], names: list[str], offsets: dict[str, np.ndarray],
              min_gain: float, steps: int, selected: list[str], moved: Fit
              ) -> tuple[tuple[Fit, np.ndarray, list[str]] | None, dict[str, object]]:
    """Whether ``selected``, added to ``world`` and fitted at ``moved``, stands on the first
    fit's terms (:func:`confirmed_second_look`): the larger world, its held-out residual and
    its causes, or None; and what was tried."""
    union, shown_by = world + selected, moved["shown_by"]
    sure = rmse_n(moved["left"]) <= (1.0 - min_gain) * rmse_n(fit["left"]) and (
        earn_their_place(replayer, measured, offsets, moved, world, union, min_gain, steps))
    if sure:
        moved, union = pruned(replayer, measured, offsets, moved, union, min_gain, steps)
        sure = any(c not in world for c in union) and (
            rmse_n(moved["left"]) <= (1.0 - min_gain) * rmse_n(fit["left"]))
    moved_left = (heldout_replays(replayer, measured, rows, moved, union, offsets, fit, left,
                                  min_gain, names) if sure else None)
    kept = moved_left is not None and rmse_n(moved_left) <= (1.0 - min_gain) * rmse_n(left)
    tried = {"causes": selected, "rmse_N": rmse_n(moved["left"]), "without_rmse_N":
             rmse_n(fit["left"]), **determined(
                 "heldout_rmse_N", math.nan if moved_left is None else rmse_n(moved_left),
                 "not replayed: the logs fitted do not confirm the causes"),
             "without_heldout_rmse_N": rmse_n(left), "shown_by": shown_by, "kept": kept}
    return ((moved, moved_left, union) if kept else None), tried


def second_look_record(tried: list[dict[str, object]]) -> dict[str, object]:
    """What the second look tried, as ``second_look`` gives it: the last attempt, and the
    earlier ones (the signatures' choice that did not stand) under ``before``."""
    return {**tried[-1], **({"before": tried[:-1]} if len(tried) > 1 else {})}


def earn_their_place(replayer: Replayer, measured: np.ndarray, offsets: dict[str, np.ndarray],
                     moved: Fit, world: list[str], union: list[str], min_gain: float,
                     steps: int) -> bool:
    """Whether the causes the second look adds to ``world`` (``union``: both, fitted at
    ``moved``) earn their place: ``world``'s causes alone, from where ``moved`` holds them,
    refitted by Gauss-Newton's steps (:func:`~cell.logs.search.gauss_newton`, no line
    search), stay more than ``min_gain`` (a share) above ``moved``'s error. A first fit can
    stop short of its causes' best, and a cause added beside them then only takes up the
    rest: one refit tells, before the backward elimination refits the world without each of
    its causes in turn."""
    replayer.round = "pruning"
    at = {c: moved["magnitudes"][c] for c in world}
    (replayed,) = replayer.batches([at])
    if replayed is None:
        return True
    jacobian = moved["jacobian"][:, [union.index(c) for c in world]]
    refit = gauss_newton(replayer, measured, offsets,
                         {**replayed_fit(measured, replayed, at, offsets), "jacobian": jacobian},
                         world, jacobian, steps, stretched=False)
    return (1.0 - min_gain) * rmse_n(refit["left"]) > rmse_n(moved["left"])


def second_look(replayer: Replayer, measured: np.ndarray, rows: Rows, fit: Fit,
                world: list[str], names: list[str], offsets: dict[str, np.ndarray],
                min_heldout_gain: float, steps: int, excluded: tuple[str, ...] = ()
                ) -> tuple[list[str], Fit, list[Step]]:
    """The causes a first fit hid: each of ``names`` not in ``world`` (nor ``excluded``)
    screened again in the fitted world, the fitted causes giving back its share
    (:func:`given_back`; one replay at each of its probes, near and far), the forward
    selection on what the fit leaves (of both, the part the fitted causes' signatures cannot
    take), and Gauss-Newton on ``world`` with those it adds. A cause may show only beside
    another (a binding's tearing under stiffer muscles, a gradient under a stronger seam).
    Where the selection adds none, or ``excluded`` holds the causes it chose before, the
    replays themselves are read (:func:`shown_by_replay`): the screening's, and one for each
    cause's joint step (:func:`joint_worlds`). Returns the causes selected, the best replayed
    fit with them (``fit`` where none was selected or none beat it; ``shown_by`` says which
    read found them: "signatures" or "replay") and the selection's steps."""
    others = [c for c in names if c not in world and c not in excluded]
    worlds, back = given_back(replayer, fit, world, others)
    replayed = replayer.batches(worlds)
    # Each replay with what the fitted causes gave back put back on, by their signatures: the
    # cause's own step at the fit.
    stepped = [None if vector is None else vector + fit["jacobian"] @ moved
               for vector, moved in zip(replayed, back, strict=True)]
    blocks = signatures(fit["left"], fit["simulated"], others, stepped, wide=True)
    basis = np.linalg.qr(fit["jacobian"])[0]

    def beside(vector: np.ndarray) -> np.ndarray:
        return vector - basis @ (basis.T @ vector)

    beside_blocks = {c: beside(column) for c, column in blocks.items()}
    selection = (forward_selection(beside(fit["left"]), beside_blocks, rows, min_heldout_gain)
                 if not excluded else [scored_step(beside(fit["left"]), {}, "", rows)])
    added = [step.added for step in selection[1:]]
    start = fit
    if not added:
        joint = joint_worlds(measured, fit, world, blocks, offsets, min_heldout_gain)
        shown = shown_by_replay(measured, fit, worlds + joint,
                                replayed + replayer.batches(joint), offsets, min_heldout_gain)
        if shown is None or shown[0] not in blocks:
            return [], fit, selection
        cause, start = shown
        added = [cause]
        selection = [*selection, scored_step(beside(fit["left"]),
                                             {cause: beside_blocks[cause]}, cause, rows)]
    union = world + added
    jacobian = np.concatenate([fit["jacobian"]] + [blocks[c] for c in added], axis=1)
    moved = gauss_newton(replayer, measured, offsets, {**start, "jacobian": jacobian}, union,
                         jacobian, steps)
    return added, {**moved, "shown_by": "replay" if start is not fit else "signatures"}, selection


def given_back(replayer: Replayer, fit: Fit, world: list[str], others: list[str]
               ) -> tuple[list[dict[str, float]], list[np.ndarray]]:
    """The worlds that screen each of ``others`` at each of its probes, near and far
    (:func:`~cell.logs.search.screening_worlds`, wide: a big change shows only far) beside
    ``fit``, with ``world``'s causes moved back by what that step did in the lab's world
    (its screening replay there, replayed already, taken by their signatures at the fit,
    least squares), and how far each world moved them back. The first fit let the causes it
    holds take the share of a cause it lacks (muscles stiffer for fibres turned along the
    pull): added alone at the fit, the cause counts its share twice and shows little; with
    the share given back, its replay is one the logs can tell apart. Each step gives back
    its own share: a fibre turned either way stiffens alike."""
    steps = screening_worlds(others, {}, wide=True)
    base, *lab = replayer.batches([{}, *steps])
    current = np.array([fit["magnitudes"][c] for c in world])
    worlds, back = [], []
    for at, vector in zip(steps, lab, strict=True):
        share = (np.zeros(len(world)) if vector is None or base is None else
                 np.linalg.lstsq(fit["jacobian"], vector - base, rcond=None)[0])
        moved = bounded(world, current - share)
        worlds.append({**dict(zip(world, moved.tolist(), strict=True)), **at})
        back.append(current - moved)
    return worlds, back


def shown_by_replay(measured: np.ndarray, fit: Fit, worlds: list[dict[str, float]],
                    replayed: list[np.ndarray | None], offsets: dict[str, np.ndarray],
                    min_gain: float) -> tuple[str, Fit] | None:
    """The cause of the second look's replay (one of ``worlds``: ``fit``'s causes, moved or
    not, and one cause more) that fits the logs closest, and that replay's fit, where
    it lowers ``fit``'s error by ``min_gain`` (a share); else None. A binding's change beside
    a strong change of the muscles moves a few tears and the force after them: the replay at
    the screening step shows it, a signature taken as a slope over both steps can blur it,
    and the fitted causes' signatures beside it can take its linear part."""
    best: tuple[str, Fit] | None = None
    for at, vector in zip(worlds, replayed, strict=True):
        if vector is None:
            continue
        trial = replayed_fit(measured, vector, at, offsets)
        if best is None or rmse_n(trial["left"]) < rmse_n(best[1]["left"]):
            best = (next(c for c in at if c not in fit["magnitudes"]), trial)
    if best is None or rmse_n(best[1]["left"]) > (1.0 - min_gain) * rmse_n(fit["left"]):
        return None
    return best


def joint_worlds(measured: np.ndarray, fit: Fit, world: list[str], blocks: dict[str, np.ndarray],
                 offsets: dict[str, np.ndarray], min_gain: float) -> list[dict[str, float]]:
    """For each cause of ``blocks``, the world that one Gauss-Newton step from ``fit`` gives
    ``world``'s causes and it together (its signature beside theirs), where that step's linear
    fit lowers ``fit``'s error by ``min_gain`` (a share). A binding's change beside a strong
    change of the muscles is partly taken by the muscles' magnitude in the first fit: added
    alone at the fit, it shows little; the joint step gives back what it takes."""
    residual = measured - fit["simulated"]
    current = np.array([fit["magnitudes"][c] for c in world])
    worlds = []
    for cause, column in blocks.items():
        both = [*world, cause]
        fitted, left = solve(residual, {"world": np.concatenate([fit["jacobian"], column], 1),
                                        **offsets}, None, fixed(offsets))
        if rmse_n(left) > (1.0 - min_gain) * rmse_n(fit["left"]):
            continue
        target = bounded(both, np.append(current, 0.0) + fitted["world"])
        worlds.append(dict(zip(both, target.tolist(), strict=True)))
    return worlds
