"""The replays' chaos as noise in the log diagnosis (:mod:`cell.logs.diagnosis`): each force
sample compared weighed by how well a replay can predict it.

Before the first tear a replay follows its log to the sensor's noise; after a tear, which
binding went and when turns on a hair, and the force for seconds after with it. Replayed with
every cause nudged by 1 % (:func:`~cell.logs.nudges.nudges`), the lab's world shows where:
the spread of those replays at each sample is the part of the error no world can take away
there. Each compared sample's error is weighed by the inverse of its variance, the log's
sensor noise averaged over the compared window plus that spread, so that the deterministic
stretches speak and the chaotic ones do not drown them (least squares with each sample's own
noise). The weights average 1 over the force samples: the errors stay in N, a weighted RMS.

Example:
    >>> samples_averaged(0.2, 0.01)
    20.0
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from cell.logs.fit import COMPARED_WINDOW_S, FORCE_CHANNELS, Rows, compared
from cell.logs.outcome import control_step_s
from cell.measure.logs import SeparationLog


def samples_averaged(window_s: float, step_s: float) -> float:
    """The samples a compared window averages at a sampling step of ``step_s`` (s), at least
    one."""
    return max(window_s / step_s, 1.0) if step_s > 0.0 else 1.0


def chaos_variance(logs: Sequence[SeparationLog], rows: Rows, replays: Sequence[np.ndarray]
                   ) -> np.ndarray:
    """(n,) the variance of ``replays`` (a world's replays of the batch, nudged) at each
    entry of the batch vector, N², smoothed over the compared window on each channel (five
    replays say little of one sample alone, and a tear's spread lasts); 0 beyond the
    forces."""
    spread = np.var(np.stack(replays), axis=0)
    out = np.zeros(spread.size)
    for i, log in enumerate(logs):
        for c, name in enumerate(FORCE_CHANNELS):
            at = (rows.log == i) & (rows.channel == c)
            out[at] = compared(log, name, spread[at].reshape(-1, 3)).ravel()
    return out


def noise_variance(logs: Sequence[SeparationLog], rows: Rows, noise_n: float) -> np.ndarray:
    """(n,) the variance of the sensor's noise ``noise_n`` (N, a sample's) averaged over the
    compared window, at each force entry of the batch vector, N²; 0 beyond the forces."""
    out = np.zeros(rows.log.size)
    for i, log in enumerate(logs):
        out[(rows.log == i) & rows.force] = noise_n ** 2 / samples_averaged(
            COMPARED_WINDOW_S, control_step_s(log))
    return out


def chaos_scales(logs: Sequence[SeparationLog], rows: Rows, replays: Sequence[np.ndarray],
                 noise_n: float) -> np.ndarray:
    """(n,) the factor on each entry of the batch vector: the square root of its weight, the
    inverse of the sensor's noise averaged over the compared window (:func:`noise_variance`)
    plus the replays' spread there (:func:`chaos_variance`), scaled so that the weights
    average 1 over the force entries; 1 beyond the forces (their own noise is in their
    units: :mod:`cell.logs.outcome`)."""
    variance = chaos_variance(logs, rows, replays) + noise_variance(logs, rows, noise_n)
    force = rows.force & (variance > 0.0)
    weight = np.ones(rows.log.size)
    if force.any():
        weight[force] = 1.0 / variance[force]
        weight[force] /= weight[force].mean()
    return np.sqrt(weight)
