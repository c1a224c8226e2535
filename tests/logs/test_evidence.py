"""What the log diagnosis says of its causes beyond the fit (cell.logs.evidence): a cause
screened that explains the logs as well as a named one is reported beside it, with the channel
where the two differ most; one that explains less is not. A cause the named ones stand in for
is reported as undetermined beside them; one the logs rule out, or cannot see at all, is not."""

from __future__ import annotations

import numpy as np

from cell.logs.evidence import indistinguishable, undetermined_beside
from cell.logs.fit import FORCE_CHANNELS, Rows

#: Three logs, each with every force channel's three components over 20 samples, then one
#: outcome entry (the torn count).
_LOGS, _SAMPLES = 3, 20


def _rows() -> Rows:
    log, channel, axis = [], [], []
    for i in range(_LOGS):
        for c in range(len(FORCE_CHANNELS)):
            log += [i] * 3 * _SAMPLES
            channel += [c] * 3 * _SAMPLES
            axis += [0, 1, 2] * _SAMPLES
        log, channel, axis = [*log, i], [*channel, len(FORCE_CHANNELS)], [*axis, 0]
    return Rows(np.array(log), np.array(channel), np.array(axis))


def test_a_cause_that_explains_the_logs_as_well_is_named_with_where_they_differ() -> None:
    rows, rng = _rows(), np.random.default_rng(0)
    lowered_threshold = rng.normal(size=(len(rows.log), 1))
    stiffer_bindings = lowered_threshold.copy()
    gripper = rows.channel == FORCE_CHANNELS.index("gripper")
    stiffer_bindings[gripper] *= 1.1  # alike everywhere but a little on the gripper
    softer_muscles = rng.normal(size=(len(rows.log), 1))
    # The noise is what the logs cannot explain: beside it the gripper's share is not seen.
    residual = 0.5 * lowered_threshold[:, 0] + rng.normal(0.0, 0.2, len(rows.log))
    blocks = {"tearing_threshold": lowered_threshold, "binding_strength": stiffer_bindings,
              "tissue_stiffness": softer_muscles}
    found = indistinguishable(residual, blocks, rows, ["tearing_threshold"],
                              ["tearing_threshold"], 0.08)
    assert [(f.cause, f.alternative, f.differs_most) for f in found] == [
        ("tearing_threshold", "binding_strength", "gripper")]
    named, alternative = found[0].heldout_rmse_n, found[0].alternative_heldout_rmse_n
    assert named < alternative < named / (1.0 - 0.08)


def test_nothing_is_reported_beside_a_cause_nothing_else_explains() -> None:
    rows, rng = _rows(), np.random.default_rng(1)
    named = rng.normal(size=(len(rows.log), 1))
    blocks = {"tearing_threshold": named, "tissue_stiffness": rng.normal(size=(len(rows.log), 1)),
              "sensor_offset:knife": rows.offset_columns("knife")}
    residual = 0.5 * named[:, 0] + rng.normal(0.0, 0.01, len(rows.log))
    assert indistinguishable(residual, blocks, rows, ["tearing_threshold"],
                             ["tearing_threshold"], 0.08) == []


def _threshold_and_bindings(rng: np.random.Generator, alike: float
                            ) -> tuple[Rows, dict[str, np.ndarray]]:
    """A lowered threshold's signature and stiffer bindings' made of ``alike`` of it and the
    rest their own (a gripper's force before the first tear)."""
    rows = _rows()
    lowered_threshold = rng.normal(size=(len(rows.log), 1))
    own = np.zeros_like(lowered_threshold)
    gripper = rows.channel == FORCE_CHANNELS.index("gripper")
    own[gripper] = rng.normal(size=(int(gripper.sum()), 1))
    stiffer_bindings = alike * lowered_threshold + (1.0 - alike) * own
    return rows, {"tearing_threshold": lowered_threshold, "binding_stiffness": stiffer_bindings,
                  "sensor_offset:knife": rows.offset_columns("knife")}


def test_a_cause_the_named_one_stands_in_for_is_undetermined_beside_it() -> None:
    rng = np.random.default_rng(2)
    rows, blocks = _threshold_and_bindings(rng, alike=0.97)
    # Both changes at once; the threshold alone takes nearly all of it.
    residual = (-0.5 * blocks["tearing_threshold"][:, 0] + 0.4 * blocks["binding_stiffness"][:, 0]
                + rng.normal(0.0, 0.3, len(rows.log)))
    found = undetermined_beside(residual, blocks, rows, ["tearing_threshold"],
                                ["tearing_threshold"], 0.08)
    assert [(f.cause, f.beside, f.differs_most) for f in found] == [
        ("binding_stiffness", ("tearing_threshold",), "gripper")]
    assert found[0].low <= 0.0 and found[0].high >= np.log(1.3)
    assert found[0].to_json()["high"]["factor"] == np.exp(found[0].high)


def test_a_cause_the_logs_rule_out_or_cannot_see_is_not_undetermined() -> None:
    rng = np.random.default_rng(3)
    rows, blocks = _threshold_and_bindings(rng, alike=0.2)
    residual = -0.5 * blocks["tearing_threshold"][:, 0] + rng.normal(0.0, 0.05, len(rows.log))
    # Told apart by their own parts: the bindings are ruled out at their typical size.
    assert undetermined_beside(residual, blocks, rows, ["tearing_threshold"],
                               ["tearing_threshold"], 0.08) == []
    # A change the logs cannot see at all, beside the threshold or not, is no stand-in's.
    faint = {**blocks, "binding_stiffness": 1e-4 * blocks["binding_stiffness"]}
    assert undetermined_beside(residual, faint, rows, ["tearing_threshold"],
                               ["tearing_threshold"], 0.08) == []
    assert undetermined_beside(residual, blocks, rows, [], [], 0.08) == []
