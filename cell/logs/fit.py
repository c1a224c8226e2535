"""The linear algebra of the batch diagnosis of separation logs (MuJoCo-free): the logged
and simulated force channels of a batch stacked into one vector, the causes' linearised
signatures as columns beside it, their magnitudes by least squares, a sensor's offset in
closed form (three constant columns of its channel), and the greedy forward selection with
an information criterion and the logs left out one at a time.

A log's vector holds its force channels (:data:`FORCE_CHANNELS`, N, each in its sensor's
frame), every sample's three components, channel after channel; a batch's vector the logs'
one after another. The residual is the logged minus the simulated vector: the signature of a
world cause is the change of the simulated vector per unit of its magnitude (one perturbed
replay), so that a magnitude ``m`` explains ``J m`` of the residual.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from cell.diagnosis.engine.statistics import bic
from cell.measure.logs import CHANNELS, Channel, SeparationLog

#: The force channels compared and fitted (``heldout_rmse_N`` is over these): every channel
#: of the log format (:data:`~cell.measure.logs.CHANNELS`).
FORCE_CHANNELS = tuple(CHANNELS)
#: The time over which the logged and the replayed forces are compared, s: both are averaged
#: over it (:func:`averaged`). A replay's tools follow the logged poses within a tenth of a
#: millimetre, but the meat's sharp events (the edge through a binding, a tear) fall a control
#: step or two from the log's, in the true world as in any other: chaos of contact, not a
#: cause, which sample by sample costs newtons at every spike. The causes act over seconds of
#: cutting and pulling, and outlast the average.
COMPARED_WINDOW_S = 0.2


@dataclass(frozen=True)
class Rows:
    """Where each sample of a batch's vector lies.

    Attributes:
        log: (n,) the log's index of each entry.
        channel: (n,) its channel's index in :data:`FORCE_CHANNELS`.
        axis: (n,) its component (0, 1, 2).
        resting: (n,) whether it was sampled before its sensor's tare and the knife's first
            cut (None: all).
        tared: (n,) whether it was sampled at or after its sensor's tare (None: none was).

    An entry on the channel index ``len(FORCE_CHANNELS)`` is a misfit beyond the forces (a
    count or an event, :mod:`cell.logs.outcome`).

    Example:
        >>> rows = Rows(np.zeros(6, int), np.array([0, 0, 0, 2, 2, 2]), np.tile([0, 1, 2], 2))
        >>> rows.offset_columns("fixture")[:, 0].tolist()
        [0.0, 0.0, 0.0, 1.0, 0.0, 0.0]
    """

    log: np.ndarray
    channel: np.ndarray
    axis: np.ndarray
    resting: np.ndarray | None = None
    tared: np.ndarray | None = None

    @property
    def force(self) -> np.ndarray:
        """(n,) whether each entry is a force sample's component."""
        return self.channel < len(FORCE_CHANNELS)

    def offset_columns(self, channel: str) -> np.ndarray:
        """The three columns of a constant offset of ``channel`` (N, its frame), on its samples
        before its tare: after it, the replays are re-tared to the log (:func:`retared`), which
        takes any constant there."""
        index = FORCE_CHANNELS.index(channel)
        untared = True if self.tared is None else ~self.tared
        return np.stack([((self.channel == index) & (self.axis == k) & untared).astype(float)
                         for k in range(3)], axis=1)

    def resting_offset(self, residual: np.ndarray, channel: str) -> np.ndarray:
        """A constant offset of ``channel`` as one column: the mean residual of each of its
        components at rest (:attr:`resting`; all samples where none are), where a sensor's
        offset shows alone ("also at rest": the log cause table) and the replay follows the log
        closest: a misfit of the cell while it cuts and pulls, or a replay's tare taken in a
        state a little off the log's, is not taken for one."""
        columns = self.offset_columns(channel)
        resting = self.resting if self.resting is not None and self.resting.any() else None
        fitted, _ = solve(residual, {"offset": columns}, resting)
        return columns @ fitted["offset"][:, None]


def averaged(time_s: np.ndarray, force_n: np.ndarray, split_s: float = np.inf,
             window_s: float = COMPARED_WINDOW_S) -> np.ndarray:
    """``force_n`` (samples, 3; N) at each sample the mean of the samples within
    ``window_s / 2`` of it (``time_s``, increasing, at any rate), never across ``split_s`` (a
    sensor's tare: its zero moves there).

    Example:
        >>> averaged(np.arange(5) * 0.1, np.array([[0.0], [0.0], [3.0], [0.0], [0.0]]))[:, 0]
        array([0., 1., 1., 1., 0.])
    """
    out = np.empty(force_n.shape)
    for part in (time_s < split_s, time_s >= split_s):
        if not part.any():
            continue
        t, values = time_s[part], force_n[part]
        sums = np.vstack([np.zeros((1, values.shape[1])), np.cumsum(values, axis=0)])
        low = np.searchsorted(t, t - window_s / 2 - 1e-12, "left")
        high = np.searchsorted(t, t + window_s / 2 + 1e-12, "right")
        out[part] = (sums[high] - sums[low]) / (high - low)[:, None]
    return out


def compared(log: SeparationLog, channel: str, force_n: np.ndarray) -> np.ndarray:
    """``force_n`` of ``channel`` at the log's times as the diagnosis compares it
    (:func:`averaged`, split at the sensor's tare)."""
    return averaged(log.channels[channel].time_s, force_n,
                    log.sensors.get(f"{channel}_tare_s", np.inf))


def logged_vector(logs: Sequence[SeparationLog], evidence: int = 0
                  ) -> tuple[np.ndarray, Rows]:
    """The batch's logged force channels as one vector, and where each entry lies; with
    ``evidence``, that many entries after each log's channels (on the channel index
    ``len(FORCE_CHANNELS)``, 0: the log is their reference), where a replay's misfits beyond
    the forces go (:mod:`cell.logs.outcome`)."""
    parts, log_index, channel_index, axis_index, resting, tared = [], [], [], [], [], []
    for i, log in enumerate(logs):
        first_cut = log.cut_windows_s[0][0] if log.cut_windows_s else np.inf
        for c, name in enumerate(FORCE_CHANNELS):
            force = log.channels[name].force_n
            parts.append(compared(log, name, force).ravel())
            log_index.append(np.full(force.size, i))
            channel_index.append(np.full(force.size, c))
            axis_index.append(np.tile([0, 1, 2], len(force)))
            after_tare = tared_samples(log, name)
            resting.append(np.repeat((log.channels[name].time_s < first_cut) & ~after_tare, 3))
            tared.append(np.repeat(after_tare, 3))
        parts.append(np.zeros(evidence))
        log_index.append(np.full(evidence, i))
        channel_index.append(np.full(evidence, len(FORCE_CHANNELS)))
        axis_index.append(np.zeros(evidence, int))
        resting.append(np.zeros(evidence, bool))
        tared.append(np.zeros(evidence, bool))
    rows = Rows(*(np.concatenate(a) for a in (log_index, channel_index, axis_index, resting,
                                              tared)))
    return np.concatenate(parts), rows


def tared_samples(log: SeparationLog, channel: str) -> np.ndarray:
    """(samples,) whether each of ``channel``'s samples was read at or after its sensor's tare
    (none where the log names no tare: its sensor's zero was set before the log began, so no
    tare's draw is in it)."""
    return log.channels[channel].time_s >= log.sensors.get(f"{channel}_tare_s", np.inf)


def retared(log: SeparationLog, channel: str, simulated_n: np.ndarray) -> np.ndarray:
    """``simulated_n`` (samples, 3; N), ``channel`` replayed at the log's times, re-tared to
    the log: its samples from the tare on moved by a constant so that their mean is the log's
    there. A tare zeroes a sensor at its load of that instant, and while the meat still rings
    from being laid down (newtons on the fixture) that load is a draw of the ringing's phase,
    which a replay in a changed world never draws alike: left in, it would put a constant
    misfit on every later sample, larger than most causes' effects. The level after a tare is
    not evidence; how the force moves from there is."""
    after = tared_samples(log, channel)
    if not after.any():
        return simulated_n
    out = simulated_n.copy()
    logged = compared(log, channel, log.channels[channel].force_n)
    out[after] += (logged[after] - simulated_n[after]).mean(axis=0)
    return out


def simulated_vector(log: SeparationLog, simulated: dict[str, Channel]) -> np.ndarray:
    """One log's simulated force channels at its logged times, each re-tared to the log
    (:func:`retared`), as :func:`logged_vector` stacks them."""
    parts = []
    for name in FORCE_CHANNELS:
        t, ours = log.channels[name].time_s, simulated[name]
        at_log = np.stack([np.interp(t, ours.time_s, ours.force_n[:, k]) for k in range(3)],
                          axis=1)
        parts.append(retared(log, name, compared(log, name, at_log)).ravel())
    return np.concatenate(parts)


def rmse_n(residual: np.ndarray) -> float:
    """The RMSE of the force vectors in ``residual`` (three components a sample), N."""
    return float(np.sqrt(3.0 * np.mean(residual ** 2))) if residual.size else 0.0


def solve(residual: np.ndarray, blocks: dict[str, np.ndarray], mask: np.ndarray | None = None,
          fixed: frozenset[str] = frozenset()) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The least-squares coefficients of ``blocks`` (name -> columns) on ``residual`` (only
    the rows of ``mask`` where given), and what is left of the whole residual. The blocks
    named in ``fixed`` are fitted already (a sensor's offset at rest): they are taken whole,
    their coefficient 1."""
    taken = [name for name in blocks if name in fixed]
    if taken:
        shifted = residual - sum(blocks[name].sum(axis=1) for name in taken)
        fitted, left = solve(shifted, {k: v for k, v in blocks.items() if k not in fixed}, mask)
        return {**fitted, **{name: np.ones(1) for name in taken}}, left
    if not blocks:
        return {}, residual.copy()
    names = list(blocks)
    design = np.concatenate([blocks[name] for name in names], axis=1)
    rows = slice(None) if mask is None else mask
    scale = np.linalg.norm(design[rows], axis=0)
    scale[scale == 0.0] = 1.0
    coefficients = np.linalg.lstsq(design[rows] / scale, residual[rows], rcond=None)[0] / scale
    split = np.cumsum([blocks[name].shape[1] for name in names])[:-1]
    fitted = dict(zip(names, np.split(coefficients, split), strict=True))
    return fitted, residual - design @ coefficients


def signature(residual: np.ndarray, sides: Sequence[tuple[float, np.ndarray | None]]
              ) -> np.ndarray | None:
    """A cause's signature (one column) from its screening replays ``sides`` (the magnitude
    and the change of the simulated vector it gave; None where the replay blew up): of the
    secants, the one that explains ``residual`` best with a magnitude on its own side. A
    cause may act otherwise one way than the other (softer muscles tear bindings that
    stiffer ones do not), or alike both ways (the fibres turned either way)."""
    best, best_left = None, np.inf
    for step, change in sides:
        if change is None:
            continue
        column = (change / step)[:, None]
        fitted, left = solve(residual, {"cause": column})
        consistent = fitted["cause"][0] * step >= 0.0
        score = float(left @ left) if consistent else np.inf
        if best is None or score < best_left:
            best, best_left = column, score
    return best


def heldout(residual: np.ndarray, blocks: dict[str, np.ndarray], rows: Rows,
            fixed: frozenset[str] = frozenset()) -> np.ndarray:
    """Leave one log out: each log's residual after the blocks fitted on the other logs
    (``fixed`` ones as in :func:`solve`)."""
    left = np.empty_like(residual)
    for i in np.unique(rows.log):
        mine = rows.log == i
        rest = solve(residual, blocks, ~mine, fixed)[1] if blocks else residual
        left[mine] = rest[mine]
    return left


def decorrelation_rows(residual: np.ndarray, rows: Rows) -> int:
    """How many samples apart a residual's series forget each other (the median over the
    logs' channel components of the first lag where the autocorrelation falls below 1/e):
    the information criterion counts one sample per such stretch."""
    lags = []
    for i in np.unique(rows.log):
        for c in range(len(FORCE_CHANNELS)):
            for k in range(3):
                series = residual[(rows.log == i) & (rows.channel == c) & (rows.axis == k)]
                series = series - series.mean()
                if series.size < 4 or not series.any():
                    continue
                full = np.correlate(series, series, "full")[series.size - 1:]
                below = np.flatnonzero(full / full[0] < np.exp(-1.0))
                lags.append(int(below[0]) if below.size else series.size)
    return max(1, int(np.median(lags))) if lags else 1


def information(residual: np.ndarray, parameters: int, stretch: int) -> float:
    """The Bayesian information criterion of a residual with ``parameters`` fitted, on one
    sample per ``stretch`` (:func:`decorrelation_rows`)."""
    n = max(residual.size / stretch, 2.0)
    return bic(float(np.mean(residual ** 2)) * n, n, parameters)


@dataclass(frozen=True)
class Step:
    """One step of the forward selection: the block added, and the criterion and the held-out
    RMSE (N, linearised) with it.

    Example:
        >>> Step("binding_strength", -120.0, 0.9).added
        'binding_strength'
    """

    added: str
    information: float
    heldout_rmse_n: float


def scored_step(residual: np.ndarray, blocks: dict[str, np.ndarray], added: str, rows: Rows,
                fixed: frozenset[str] = frozenset()) -> Step:
    """The step that brings ``blocks`` (``added`` the last of them; "" for none) into the
    fit of ``residual``: its information criterion and linearised held-out RMSE."""
    _, left = solve(residual, blocks, None, fixed)
    size = sum(3 if b in fixed else blocks[b].shape[1] for b in blocks)
    return Step(added, information(left, size, decorrelation_rows(residual, rows)),
                rmse_n(heldout(residual, blocks, rows, fixed)))


def forward_selection(residual: np.ndarray, blocks: dict[str, np.ndarray], rows: Rows,
                      min_heldout_gain: float, fixed: frozenset[str] = frozenset()
                      ) -> list[Step]:
    """Add, one at a time, the block that lowers the linearised held-out error most, as long
    as the information criterion falls and the held-out RMSE falls by ``min_heldout_gain``
    (a share) of the current one (``fixed`` blocks as in :func:`solve`, three parameters
    each). The first step is the start: ``added`` is ""."""
    chosen: dict[str, np.ndarray] = {}
    steps = [scored_step(residual, {}, "", rows)]
    while len(chosen) < len(blocks):
        trials = [scored_step(residual, {**chosen, name: blocks[name]}, name, rows, fixed)
                  for name in blocks.keys() - chosen.keys()]
        best = min(trials, key=lambda step: step.heldout_rmse_n)
        last = steps[-1]
        if (best.information >= last.information
                or best.heldout_rmse_n > (1.0 - min_heldout_gain) * last.heldout_rmse_n):
            break
        chosen[best.added] = blocks[best.added]
        steps.append(best)
    return steps


def broyden(jacobian: np.ndarray, step: np.ndarray, change: np.ndarray) -> np.ndarray:
    """The signatures (columns) updated so that they explain the simulated vector's
    ``change`` over the magnitudes' ``step`` (Broyden's rank-one update)."""
    norm = float(step @ step)
    if norm == 0.0:
        return jacobian
    return jacobian + np.outer(change - jacobian @ step, step) / norm
