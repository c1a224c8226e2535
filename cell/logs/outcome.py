"""The evidence of a separation log beyond its force samples (docs/logs.md, "The outcome and
the release events"): the ``[outcome]`` counts (bindings released, torn) and when the
releases happened (the largest drop of the gripper's, the fixture's and the knife's force),
each compared with a replay's in units of its own noise.

A count's noise is binomial over the bindings at the logged share, never below
:data:`COUNT_FLOOR`; an event's time is known to :data:`EVENT_STEPS` control steps, and a
miss (one side has no release where the other has) costs :data:`EVENT_CAP` noise widths at
most, so that one odd drop does not outweigh every force sample. The diagnosis weighs these
standardised misfits beside the force residual (:func:`evidence_weight`).

Example:
    >>> EVIDENCE_ROWS
    5
"""

from __future__ import annotations

import numpy as np

from cell.measure.logs import Channel, SeparationLog

#: The counts of ``[outcome]`` compared.
COUNTS = ("released", "torn")
#: The channels whose largest force drop is a release event.
EVENT_CHANNELS = ("gripper", "fixture", "knife")
#: The entries a log adds to the compared vector: its counts, then its events.
EVIDENCE_ROWS = len(COUNTS) + len(EVENT_CHANNELS)
#: The least noise of a count (bindings): a replay a binding or two off is within noise.
COUNT_FLOOR = 2.0
#: The timing noise of a release event, control steps.
EVENT_STEPS = 3
#: The most noise widths an event's misfit counts.
EVENT_CAP = 3.0
#: A drop is a release event where it is at least this share of the channel's peak force.
EVENT_SHARE = 0.25


def release_time_s(channel: Channel, lag: int) -> float | None:
    """When ``channel``'s force magnitude fell most over ``lag`` samples (the start of the
    drop), s; None where that drop is under :data:`EVENT_SHARE` of its peak."""
    magnitude = np.linalg.norm(channel.force_n, axis=1)
    if magnitude.size <= lag or not magnitude.max() > 0.0:
        return None
    drops = magnitude[:-lag] - magnitude[lag:]
    i = int(np.argmax(drops))
    return float(channel.time_s[i]) if drops[i] >= EVENT_SHARE * magnitude.max() else None


def control_step_s(log: SeparationLog) -> float:
    """The log's sampling step (the cell samples every control step), s."""
    t = log.channels["knife"].time_s
    return float(np.median(np.diff(t))) if t.size > 1 else 0.0


def count_misfits(logged: dict[str, int], replayed: dict[str, int]) -> np.ndarray:
    """Each of :data:`COUNTS`: the replay's count minus the log's in noise widths (0 where the
    log has no ``[outcome]``)."""
    bindings = max(int(logged.get("bindings", replayed.get("bindings", 0))), 1)
    out = np.zeros(len(COUNTS))
    for k, key in enumerate(COUNTS):
        if key not in logged:
            continue
        share = min(max(logged[key] / bindings, 0.0), 1.0)
        noise = max(float(np.sqrt(bindings * share * (1.0 - share))), COUNT_FLOOR)
        out[k] = (replayed[key] - logged[key]) / noise
    return out


def event_misfits(log: SeparationLog, simulated: dict[str, Channel]) -> np.ndarray:
    """Each of :data:`EVENT_CHANNELS`: the replay's release time minus the log's in noise
    widths (:data:`EVENT_STEPS` control steps), within :data:`EVENT_CAP`; a release on one side
    only costs the cap, none on either nothing."""
    step = control_step_s(log)
    lag = EVENT_STEPS
    out = np.zeros(len(EVENT_CHANNELS))
    for k, name in enumerate(EVENT_CHANNELS):
        ours, theirs = (release_time_s(simulated[name], lag),
                        release_time_s(log.channels[name], lag))
        if ours is None and theirs is None:
            continue
        if ours is None or theirs is None or step <= 0.0:
            out[k] = EVENT_CAP
            continue
        out[k] = float(np.clip((ours - theirs) / (EVENT_STEPS * step), -EVENT_CAP, EVENT_CAP))
    return out


def evidence_misfits(log: SeparationLog, simulated: dict[str, Channel],
                     released: dict[str, int]) -> np.ndarray:
    """A replay's :data:`EVIDENCE_ROWS` misfits against ``log`` (counts, then events), in
    noise widths."""
    return np.concatenate([count_misfits(log.outcome, released),
                           event_misfits(log, simulated)])


def count_entries(evidence: np.ndarray) -> np.ndarray:
    """(n,) whether each entry of a batch vector is a count's misfit, given ``evidence``
    ((n,) whether it is a misfit beyond the forces: each log's :data:`EVIDENCE_ROWS`, its
    counts first)."""
    out = np.zeros(evidence.size, bool)
    at = np.flatnonzero(evidence)
    out[at[np.arange(at.size) % EVIDENCE_ROWS < len(COUNTS)]] = True
    return out


def evidence_weight(force_rmse_n: float, stretch: int) -> float:
    """The weight (N a noise width) that puts a standardised misfit beside the force
    residual: the force residual's per-component RMS (its error scale) times the square root
    of the samples one independent force sample spans (``stretch``), so that a misfit of one
    noise width counts as one independent force sample off by the residual's scale."""
    return float(force_rmse_n / np.sqrt(3.0) * np.sqrt(max(stretch, 1)))
