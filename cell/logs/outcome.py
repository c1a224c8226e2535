"""The evidence of a separation log beyond its force samples (docs/logs.md, "The outcome and
the release events"): the ``[outcome]`` counts (bindings released, torn) and when the
releases happened (the largest drop of the gripper's, the fixture's and the knife's force),
each compared with a replay's in units of its own noise.

A count's noise is binomial over the bindings at the logged share, never below
:data:`COUNT_FLOOR`; an event's time is known to :data:`EVENT_STEPS` control steps, each
side's release is matched with the other side's nearest drop of a comparable size, and a
miss (one side has no such drop where the other has a release) costs :data:`EVENT_CAP`
noise widths at most, so that one odd drop does not outweigh every force sample. The
diagnosis weighs these standardised misfits beside the force residual (:func:`evidence_weight`).

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
#: A drop matches a release on the other side where it is at least this share of the
#: release's size (a share of each side's own peak): a drop's size varies from one run to
#: the next as much as the meat's ringing, and the event's share is a cut-off, not a size.
MATCH_SHARE = 0.5


def relative_drops(channel: Channel, lag: int) -> tuple[np.ndarray, np.ndarray]:
    """Each sample's time, s, and how far ``channel``'s force magnitude falls over the
    ``lag`` samples from it, as a share of its peak (none where it has no force)."""
    magnitude = np.linalg.norm(channel.force_n, axis=1)
    if magnitude.size <= lag or not magnitude.max() > 0.0:
        return np.empty(0), np.empty(0)
    return channel.time_s[:-lag], (magnitude[:-lag] - magnitude[lag:]) / magnitude.max()


def _matched_s(event: tuple[float, float], other: tuple[np.ndarray, np.ndarray]
               ) -> float | None:
    """The time nearest ``event`` (time, s, and its drop's share) of the ``other`` side's
    drops at least :data:`MATCH_SHARE` of its size; None where it has none."""
    time_s, drops = other
    near = time_s[drops >= MATCH_SHARE * event[1]]
    return float(near[np.argmin(np.abs(near - event[0]))]) if near.size else None


def event_misfit(logged: Channel, simulated: Channel, step_s: float) -> float:
    """The replay's release on one channel against the log's, in noise widths (time, replay
    minus log): each side's release (its largest drop, at least :data:`EVENT_SHARE` of its
    peak) against the other side's nearest drop of a comparable size (:func:`_matched_s`),
    the larger of the two misfits, within :data:`EVENT_CAP`; a release with no comparable
    drop on the other side costs the cap, none on either side nothing. Two drops of about the
    same size decide which is largest by chance, in the log as in any replay (the edge
    through one binding or the next): the release is where the other side drops alike, not
    where its own largest drop happens to be."""
    lag = EVENT_STEPS
    sides = relative_drops(logged, lag), relative_drops(simulated, lag)
    worst = 0.0
    for k, (time_s, drops) in enumerate(sides):
        if not drops.size or drops.max() < EVENT_SHARE:
            continue
        i = int(np.argmax(drops))
        matched = _matched_s((float(time_s[i]), float(drops[i])), sides[1 - k])
        if matched is None or step_s <= 0.0:
            return EVENT_CAP
        ours, theirs = (matched, time_s[i]) if k == 0 else (time_s[i], matched)
        misfit = float(np.clip((ours - theirs) / (EVENT_STEPS * step_s), -EVENT_CAP,
                               EVENT_CAP))
        worst = misfit if abs(misfit) > abs(worst) else worst
    return worst


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
    """Each of :data:`EVENT_CHANNELS`: :func:`event_misfit` of the replay against ``log``."""
    step = control_step_s(log)
    return np.array([event_misfit(log.channels[name], simulated[name], step)
                     for name in EVENT_CHANNELS])


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
