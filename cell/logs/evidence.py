"""The evidence of the log diagnosis, in the engine's shape
(:class:`cell.diagnosis.engine.outcome.Evidence`): per named cause, the held-out force RMSE of
the logs with the extended world (replayed) and without the cause (linearised), and the share
of the logs it improves.

Example:
    >>> LogEvidence("tissue_stiffness", 0.4, 2.0, 1.0, {}, None).to_json()["linearised"]
    True
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from cell.diagnosis.engine.determined import NOT_PREDICTED, determined
from cell.diagnosis.engine.outcome import Evidence
from cell.logs.causes import magnitudes_json
from cell.logs.fit import FORCE_CHANNELS, Rows, heldout, rmse_n, solve
from cell.logs.search import OFFSET, fixed


@dataclass(frozen=True)
class LogEvidence(Evidence):
    """:class:`~cell.diagnosis.engine.outcome.Evidence` for a cause of the logs: its
    ``improved_fraction`` is the share of the logs (each held out) whose error it lowers, its
    ``params`` empty (the magnitudes are the extended world's ``params``; the log diagnosis
    gives no intervals), ``without`` None.

    Attributes:
        channel: the channel of a ``sensor_offset`` ("" for a world cause).
        linearised: the error without the cause is linearised (from the signatures), the one
            with it replayed.

    Example:
        >>> LogEvidence("sensor_offset", 0.4, 2.0, 1.0, {}, None, channel="knife"
        ...             ).to_json()["channel"]
        'knife'
    """

    channel: str = ""
    linearised: bool = True

    def to_json(self) -> dict[str, Any]:
        """The engine's ``evidence`` entry, with the channel (an offset's) and
        ``linearised``."""
        return {**super().to_json(), **({"channel": self.channel} if self.channel else {}),
                "linearised": self.linearised}


def log_evidence(residual: np.ndarray, blocks: dict[str, np.ndarray], rows: Rows,
                 chosen: list[str], left: np.ndarray) -> list[LogEvidence]:
    """Per named block (a world cause, or a sensor's offset on a channel), the held-out RMSE
    of the logs with the extended world (``left``, replayed) and without the block
    (linearised), and the share of the logs it improves."""
    out = []
    for name in chosen:
        others = {c: blocks[c] for c in chosen if c != name}
        without = heldout(residual, others, rows, fixed(others))
        logs = np.unique(rows.log)
        better = [rmse_n(left[rows.log == i]) < rmse_n(without[rows.log == i]) for i in logs]
        cause, _, channel = name.partition(":") if name.startswith(OFFSET) else (name, "", "")
        out.append(LogEvidence(cause, rmse_n(left), rmse_n(without), float(np.mean(better)),
                               {}, None, channel=channel))
    return out


@dataclass(frozen=True)
class Indistinguishable:
    """A cause the batch cannot tell from a named one: swapped in for it (the other named
    blocks kept), its held-out RMSE (linearised) is not worse by the share a cause must earn
    to be named (the diagnosis's ``min_heldout_gain``).

    Attributes:
        cause: the named world cause.
        alternative: the world cause screened that explains the logs as well.
        heldout_rmse_n: the held-out force RMSE (linearised) with ``cause``, N.
        alternative_heldout_rmse_n: the same with ``alternative`` in its place, N.
        differs_most: where the two causes' fitted changes differ most: a force channel
            (``knife``, ``gripper``, ``fixture``) or ``outcome`` (the counts and the release
            events): what a log that tells them apart must show.

    Example:
        >>> Indistinguishable("a", "b", 0.5, 0.52, "gripper").to_json()["alternative"]
        'b'
    """

    cause: str
    alternative: str
    heldout_rmse_n: float
    alternative_heldout_rmse_n: float
    differs_most: str

    def to_json(self) -> dict[str, Any]:
        """The JSON's ``indistinguishable`` entry."""
        return {"cause": self.cause, "alternative": self.alternative,
                **determined("heldout_rmse_N", self.heldout_rmse_n, NOT_PREDICTED),
                **determined("alternative_heldout_rmse_N", self.alternative_heldout_rmse_n,
                             NOT_PREDICTED),
                "differs_most": self.differs_most}


def indistinguishable(residual: np.ndarray, blocks: dict[str, np.ndarray], rows: Rows,
                      chosen: list[str], world: list[str], min_gain: float
                      ) -> list[Indistinguishable]:
    """For each named world cause of ``world`` with a block (among the blocks ``chosen``),
    every other world cause screened (a block of ``blocks`` not chosen and no offset) that
    the batch cannot tell from it (:class:`Indistinguishable`)."""
    out = []
    for name in [c for c in world if c in blocks]:
        kept = {c: blocks[c] for c in chosen if c != name}
        named = rmse_n(heldout(residual, {**kept, name: blocks[name]}, rows, fixed(kept)))
        for other in blocks:
            if other in chosen or other.startswith(OFFSET):
                continue
            error = rmse_n(heldout(residual, {**kept, other: blocks[other]}, rows, fixed(kept)))
            if (1.0 - min_gain) * error <= named:
                out.append(Indistinguishable(name, other, named, error,
                                             _differs_most(residual, blocks, rows, name, other)))
    return out


def _differs_most(residual: np.ndarray, blocks: dict[str, np.ndarray], rows: Rows,
                  name: str, other: str) -> str:
    """The channel (or ``outcome``) where the changes of ``name`` and ``other``, each fitted
    alone to ``residual``, differ most (root mean square)."""
    changes = []
    for cause in (name, other):
        fitted, _ = solve(residual, {cause: blocks[cause]})
        changes.append(blocks[cause] @ fitted[cause])
    return _loudest(changes[0] - changes[1], rows)


def _loudest(difference: np.ndarray, rows: Rows) -> str:
    """The channel (or ``outcome``) where ``difference`` is largest (root mean square)."""
    places = (*FORCE_CHANNELS, "outcome")
    spread = [rmse_n(difference[rows.channel == k]) if np.any(rows.channel == k) else 0.0
              for k in range(len(places))]
    return places[int(np.argmax(spread))]


@dataclass(frozen=True)
class UndeterminedBeside:
    """A world cause the batch can neither confirm nor rule out beside the named ones: with
    them refitted, its magnitude can move over ``low`` .. ``high`` while the error of the
    logs (linearised) stays within the share a cause must earn of the named world's, a range
    that holds a change of the cause's typical size, where with the named causes held as
    fitted it does not: they stand in for it (a lower tearing threshold for stiffer bindings
    beside it, both tearing more).

    Attributes:
        cause: the world cause screened and not named.
        beside: the named world causes that stand in for it.
        low: the smallest magnitude the logs allow it (log factor, or rad).
        high: the largest.
        differs_most: where its change differs most from what the named causes can mimic:
            a force channel (``knife``, ``gripper``, ``fixture``) or ``outcome`` (the counts
            and the release events), what a log that tells them apart must show.

    Example:
        >>> UndeterminedBeside("binding_stiffness", ("tearing_threshold",), -0.1, 0.6,
        ...                    "gripper").to_json()["high"]["factor"]  # doctest: +ELLIPSIS
        1.82...
    """

    cause: str
    beside: tuple[str, ...]
    low: float
    high: float
    differs_most: str

    def to_json(self) -> dict[str, Any]:
        """The JSON's ``undetermined_beside`` entry, the magnitudes as a user reads them."""
        from cell.logs.causes import CAUSES

        return {"cause": self.cause, "beside": list(self.beside),
                "low": CAUSES[self.cause].to_json(self.low),
                "high": CAUSES[self.cause].to_json(self.high),
                "differs_most": self.differs_most}


def undetermined_beside(residual: np.ndarray, blocks: dict[str, np.ndarray], rows: Rows,
                        chosen: list[str], world: list[str], min_gain: float
                        ) -> list[UndeterminedBeside]:
    """Each world cause screened (a block of ``blocks`` not ``chosen``) that the batch can
    neither confirm nor rule out beside the named ``world`` (:class:`UndeterminedBeside`):
    on what the named blocks and the offsets leave of ``residual``, the range of its
    magnitude whose least-squares error, the named causes refitted beside it, stays within
    ``min_gain`` (a share) of the named world's holds no change (0) and one of its typical
    size, and the range with the named causes held does not reach that size."""
    from cell.logs.causes import CAUSES, bounded

    named = [c for c in world if c in blocks]
    if not named:
        return []
    offsets = {c: blocks[c] for c in chosen if c.startswith(OFFSET)}
    _, left = solve(residual, {**{c: blocks[c] for c in named}, **offsets}, None,
                    fixed(offsets))
    room = float(left @ left) / (1.0 - min_gain) ** 2
    out = []
    for other, column in blocks.items():
        if other in chosen or other not in CAUSES:
            continue
        cause = CAUSES[other]
        size = (np.radians(cause.typical[0]) if cause.kind == "angle"
                else np.log(cause.typical[0]))
        held = _allowed(left, column, room)
        design = np.concatenate([*(blocks[c] for c in named), column], axis=1)
        low, high = bounded([other, other], np.array(_allowed(left, design, room)))
        if max(abs(v) for v in held) >= size or not low <= 0.0 <= high \
                or max(-low, high) < size:
            continue
        basis = np.linalg.qr(design[:, :-1])[0]
        own = column[:, 0] - basis @ (basis.T @ column[:, 0])
        out.append(UndeterminedBeside(other, tuple(named), float(low), float(high),
                                      _loudest(own, rows)))
    return out


def _allowed(left: np.ndarray, design: np.ndarray, room: float) -> tuple[float, float]:
    """The range of the last column's coefficient over which the least-squares error of
    ``left`` on ``design`` (every other column refitted) stays within ``room`` (a sum of
    squares): the profile of a linear fit, its centre the fitted coefficient."""
    scale = np.linalg.norm(design, axis=0)
    scale[scale == 0.0] = 1.0
    coefficients, *_ = np.linalg.lstsq(design / scale, left, rcond=None)
    rest = left - (design / scale) @ coefficients
    spare = max(room - float(rest @ rest), 0.0)
    variance = np.linalg.pinv((design / scale).T @ (design / scale))[-1, -1]
    half = np.sqrt(spare * variance) / scale[-1]
    centre = coefficients[-1] / scale[-1]
    return float(centre - half), float(centre + half)


def offset_n(column: np.ndarray, rows: Rows, coefficient: np.ndarray,
             weighing: np.ndarray) -> list[float]:
    """The offset (N, each component) that an offset's column times ``coefficient`` adds,
    the column weighed as the samples are (``weighing``: each entry's factor)."""
    first = [int(np.flatnonzero((column[:, 0] != 0) & (rows.axis == k))[0])
             if ((column[:, 0] != 0) & (rows.axis == k)).any() else None for k in range(3)]
    return [0.0 if i is None else float(column[i, 0] * coefficient[0] / weighing[i])
            for i in first]


def candidates(residual: np.ndarray, blocks: dict[str, np.ndarray], rows: Rows,
               chosen: list[str], scale: np.ndarray) -> list[dict[str, Any]]:
    """Every block screened, alone: its linearised magnitude and held-out RMSE (an offset's
    in N: :func:`offset_n` with the weighing ``scale``)."""
    out = []
    for name, columns in blocks.items():
        alone = {name: columns}
        fitted, _ = solve(residual, alone, None, fixed(alone))
        entry: dict[str, Any] = {"cause": name.split(":")[0],
                                 "heldout_rmse_N": rmse_n(heldout(residual, alone, rows,
                                                                  fixed(alone))),
                                 "selected": name in chosen, "linearised": True}
        if name.startswith(OFFSET):
            entry["params"] = {"channel": name.removeprefix(OFFSET),
                               "offset_N": offset_n(columns, rows, fitted[name], scale)}
        else:
            entry["params"] = magnitudes_json({name: float(fitted[name][0])})[name]
        out.append(entry)
    return out
