"""The second look of the log diagnosis (cell.logs.second_look): where the selection on
signatures sees no cause beside the first fit's, the replays themselves are read, at the
screening step and at each cause's joint step with the causes fitted already."""

from __future__ import annotations

import zlib
from dataclasses import replace
from typing import ClassVar

import numpy as np
import pytest

import cell.logs.diagnosis as logdiagnosis
import cell.logs.second_look as look
from cell.logs.causes import CAUSES
from cell.logs.diagnosis import diagnose_logs
from cell.logs.fit import logged_vector, rmse_n
from cell.logs.nudges import JITTERS
from cell.logs.outcome import EVIDENCE_ROWS
from cell.logs.report import _spread_lines
from cell.logs.search import replayed_fit
from tests.logs.test_heldout import BATCH, PARAMS, TRUE_MAGNITUDE, HidingWorld, LinearWorld

MEASURED, ROWS = logged_vector(list(BATCH.logs), EVIDENCE_ROWS)


class SharingWorld(LinearWorld):
    """A world where a lower tearing threshold acts mostly like stiffer muscles (its pattern
    is the stiffness' twice over, and a little of its own): a fit of the stiffness alone takes
    the threshold's share and overshoots; the logs measured with both changed."""

    truth: ClassVar[dict[str, float]] = {"tissue_stiffness": TRUE_MAGNITUDE,
                                         "tearing_threshold": TRUE_MAGNITUDE}

    def effect(self, world: dict[str, float], log: int) -> np.ndarray:
        own, shared = self.patterns["tearing_threshold"][log], self.patterns[
            "tissue_stiffness"][log]
        threshold = world.get("tearing_threshold", 0.0)
        return (world.get("tissue_stiffness", 0.0) + 2.0 * threshold) * shared + 0.3 * (
            threshold * own)


def _stiffness_fit(world: LinearWorld) -> dict:
    """The first fit's: the stiffness alone, where it explains the logs best, with its
    exact signature."""
    shared = np.concatenate(world.patterns["tissue_stiffness"])
    at = {"tissue_stiffness": TRUE_MAGNITUDE * 3.0}
    (replayed,) = world.batches([at])
    return {**replayed_fit(MEASURED, replayed, at, {}), "jacobian": shared[:, None]}


def test_a_joint_step_gives_back_what_the_first_cause_took() -> None:
    world = SharingWorld(BATCH, 1)
    fit = _stiffness_fit(world)
    own = np.concatenate([0.3 * p for p in world.patterns["tearing_threshold"]])
    block = own + 2.0 * np.concatenate(world.patterns["tissue_stiffness"])
    (step,) = look.joint_worlds(MEASURED, fit, ["tissue_stiffness"],
                                {"tearing_threshold": block[:, None]}, {}, 0.08)
    assert step == pytest.approx(SharingWorld.truth, rel=0.05)


def test_no_joint_step_where_the_cause_would_not_earn_its_place() -> None:
    world = SharingWorld(BATCH, 1)
    fit = _stiffness_fit(world)
    unrelated = np.random.default_rng(1).normal(size=(MEASURED.size, 1))
    assert look.joint_worlds(MEASURED, fit, ["tissue_stiffness"],
                             {"tearing_threshold": unrelated}, {}, 0.08) == []


def test_the_replay_that_fits_closest_names_its_cause_where_it_earns_the_gain() -> None:
    world = SharingWorld(BATCH, 1)
    fit = _stiffness_fit(world)
    worlds = [{**fit["magnitudes"], "tearing_threshold": 0.4}, dict(SharingWorld.truth)]
    cause, shown = look.shown_by_replay(MEASURED, fit, worlds, world.batches(worlds), {}, 0.08)
    assert cause == "tearing_threshold"
    assert shown["magnitudes"] == SharingWorld.truth
    assert rmse_n(shown["left"]) < 0.1 * rmse_n(fit["left"])
    # A replay that does not beat the fit by the share asked names nothing.
    assert look.shown_by_replay(MEASURED, fit, worlds[:1], world.batches(worlds[:1]), {},
                                0.99) is None


def _first_selection_without_the_threshold(monkeypatch: pytest.MonkeyPatch) -> None:
    """The diagnosis's first selection as it is, less the tearing threshold."""
    selection = look.forward_selection
    monkeypatch.setattr(logdiagnosis, "forward_selection", lambda *args, **kwargs: [
        step for step in selection(*args, **kwargs) if step.added != "tearing_threshold"])


def test_a_cause_the_signatures_miss_is_found_in_the_replays(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # The selections on signatures see the stiffness alone, then nothing beside it (as where
    # a binding's tears blur the slope): the joint step's replay still shows the threshold.
    monkeypatch.setattr(logdiagnosis, "Replayer", SharingWorld)
    selection = look.forward_selection
    _first_selection_without_the_threshold(monkeypatch)
    monkeypatch.setattr(look, "forward_selection",
                        lambda *args, **kwargs: selection(*args, **kwargs)[:1])
    result = diagnose_logs(BATCH, PARAMS).to_json()
    assert sorted(result["causes"]) == sorted(SharingWorld.truth)
    tried = result["extended"]["second_look"]
    assert tried["kept"] and tried["shown_by"] == "replay"
    for cause, truth in SharingWorld.truth.items():
        assert result["extended"]["params"][cause]["magnitude"] == pytest.approx(truth,
                                                                                 rel=0.05)


class DecoyWorld(SharingWorld):
    """:class:`SharingWorld` where stiffer bindings add a pattern of their own (the muscles'
    shifted along the log) that the logs do not hold."""

    def effect(self, world: dict[str, float], log: int) -> np.ndarray:
        return super().effect(world, log) + world.get("binding_stiffness", 0.0) * np.roll(
            self.patterns["tissue_stiffness"][log], 7)


def test_where_the_signatures_choose_a_cause_that_does_not_stand_the_replays_are_read(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # The second look's signatures pick the bindings' stiffness, which the logs do not hold:
    # it does not stand, and the replays show the threshold the first fit hid.
    monkeypatch.setattr(logdiagnosis, "Replayer", DecoyWorld)
    _first_selection_without_the_threshold(monkeypatch)

    def decoy(residual: np.ndarray, blocks: dict, rows: object, *args: object) -> list:
        return [look.scored_step(residual, {}, "", rows), look.scored_step(
            residual, {"binding_stiffness": blocks["binding_stiffness"]}, "binding_stiffness",
            rows)]

    monkeypatch.setattr(look, "forward_selection", decoy)
    params = replace(PARAMS, causes=(*PARAMS.causes, "binding_stiffness"))
    result = diagnose_logs(BATCH, params).to_json()
    assert sorted(result["causes"]) == sorted(SharingWorld.truth)
    tried = result["extended"]["second_look"]
    assert tried["kept"] and tried["shown_by"] == "replay"
    (before,) = tried["before"]
    assert before["causes"] == ["binding_stiffness"] and not before["kept"]
    assert before["shown_by"] == "signatures"


class FarWorld(LinearWorld):
    """A world whose tearing threshold changes nothing within its screening step (the
    bindings far from tearing until it moves by half) and its pattern beyond, measured with
    it far moved beside stiffer muscles."""

    truth: ClassVar[dict[str, float]] = {"tissue_stiffness": TRUE_MAGNITUDE,
                                         "tearing_threshold": 0.8}

    def effect(self, world: dict[str, float], log: int) -> np.ndarray:
        threshold = world.get("tearing_threshold", 0.0)
        beyond = np.sign(threshold) * max(abs(threshold) - 0.5, 0.0)
        return (world.get("tissue_stiffness", 0.0) * self.patterns["tissue_stiffness"][log]
                + beyond * self.patterns["tearing_threshold"][log])


def test_the_second_look_screens_a_cause_far_as_well_as_near(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # The first selection sees the stiffness alone; the threshold shows at the second look
    # only in its far probes.
    monkeypatch.setattr(logdiagnosis, "Replayer", FarWorld)
    _first_selection_without_the_threshold(monkeypatch)
    result = diagnose_logs(BATCH, PARAMS).to_json()
    assert sorted(result["causes"]) == sorted(FarWorld.truth)
    assert result["extended"]["second_look"]["kept"]
    fitted = result["extended"]["params"]["tearing_threshold"]["magnitude"]
    assert fitted == pytest.approx(0.8, rel=0.05)


def test_the_signatures_find_a_hidden_cause_first(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(logdiagnosis, "Replayer", HidingWorld)
    tried = diagnose_logs(BATCH, PARAMS).to_json()["extended"]["second_look"]
    assert tried["kept"] and tried["shown_by"] == "signatures"


def test_the_fitted_causes_give_back_what_a_screened_cause_s_step_did_in_the_lab_s_world(
        ) -> None:
    world = SharingWorld(BATCH, 1)
    fit = _stiffness_fit(world)
    (up, down, *far), back = look.given_back(world, fit, ["tissue_stiffness"],
                                             ["tearing_threshold"])
    # The stiffness' pattern is the threshold's twice over: each step of the threshold gives
    # twice its size back (within the stiffness' bounds, the fit at the upper one), and the
    # step up lands near the world the logs were measured in.
    assert up["tearing_threshold"] == 0.4 and down["tearing_threshold"] == -0.4
    assert up["tissue_stiffness"] == pytest.approx(1.5 - 2.0 * 0.4, abs=0.05)
    assert down["tissue_stiffness"] == CAUSES["tissue_stiffness"].bounds[1] == 1.5
    assert back[0] == pytest.approx([0.8], abs=0.05) and back[1] == pytest.approx([0.0])
    # And at the far probes, 90 % of each bound, so that a big change is screened near its size.
    assert [w["tearing_threshold"] for w in far] == list(
        CAUSES["tearing_threshold"].probes(True)[2:])
    near, far = world.batches([up, down])
    assert rmse_n(MEASURED - near) < 0.5 * rmse_n(fit["left"]) < rmse_n(MEASURED - far)


class EvenWorld(LinearWorld):
    """A world where fibres turned either way stiffen the muscles alike (the stiffness'
    pattern times the angle squared), measured with the muscles stiffer alone."""

    truth: ClassVar[dict[str, float]] = {"tissue_stiffness": TRUE_MAGNITUDE}

    def effect(self, world: dict[str, float], log: int) -> np.ndarray:
        stiffer = world.get("tissue_stiffness", 0.0) + world.get("fibre_direction", 0.0) ** 2
        return stiffer * self.patterns["tissue_stiffness"][log]


def test_a_cause_even_in_its_magnitude_gives_back_alike_both_ways() -> None:
    world = EvenWorld(BATCH, 1)
    fit = _stiffness_fit(world)
    (up, down, *_), _ = look.given_back(world, fit, ["tissue_stiffness"], ["fibre_direction"])
    turned = 0.6 ** 2
    assert up["tissue_stiffness"] == pytest.approx(1.5 - turned)
    assert down["tissue_stiffness"] == pytest.approx(1.5 - turned)


class StandInWorld(LinearWorld):
    """A world where a lower tearing threshold acts much like stiffer muscles (its pattern
    the stiffness' and a part of its own), and the logs were measured with the muscles
    stiffer alone."""

    truth: ClassVar[dict[str, float]] = {"tissue_stiffness": TRUE_MAGNITUDE}

    def effect(self, world: dict[str, float], log: int) -> np.ndarray:
        shared = self.patterns["tissue_stiffness"][log]
        own = self.patterns["tearing_threshold"][log]
        threshold = world.get("tearing_threshold", 0.0)
        return world.get("tissue_stiffness", 0.0) * shared + threshold * (shared + 0.5 * own)


def test_a_first_cause_that_stood_in_for_the_one_the_second_look_finds_goes(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # The first selection took the threshold, which explains most of the logs: the second
    # look finds the stiffness, and the threshold, no longer needed beside it, goes.
    monkeypatch.setattr(logdiagnosis, "Replayer", StandInWorld)
    selection = look.forward_selection
    monkeypatch.setattr(logdiagnosis, "forward_selection",
                        lambda residual, blocks, *args, **kwargs: selection(
                            residual, {name: block for name, block in blocks.items()
                                       if name != "tissue_stiffness"}, *args, **kwargs))
    result = diagnose_logs(BATCH, PARAMS).to_json()
    assert result["causes"] == ["tissue_stiffness"]
    assert result["extended"]["second_look"]["kept"]
    assert [gone["cause"] for gone in result["extended"]["pruned"]] == ["tearing_threshold"]
    fitted = result["extended"]["params"]["tissue_stiffness"]["magnitude"]
    assert fitted == pytest.approx(TRUE_MAGNITUDE, rel=0.05)


class ScatteringWorld(HidingWorld):
    """:class:`HidingWorld` whose every replay carries a chaotic term (drawn from the world
    and the log) larger than what the hidden threshold leaves beside the stiffness."""

    chaos: ClassVar[float] = 1.0

    def run(self, jobs: list[tuple[int, dict[str, float]]]) -> list[np.ndarray]:
        out = super().run(jobs)
        for vector, (log, world) in zip(out, jobs, strict=True):
            seed = zlib.crc32(repr((log, sorted(world.items()))).encode())
            vector += self.chaos * np.random.default_rng(seed).normal(size=vector.size) * (
                np.arange(vector.size) < vector.size - EVIDENCE_ROWS)
        return out


def _second_look_on_the_stiffness(world: HidingWorld) -> tuple[dict, list[str], int]:
    """The second look on a fit of the stiffness alone, at its truth: the fit returned, its
    causes, and the replays it asked for."""
    at = {"tissue_stiffness": TRUE_MAGNITUDE}
    (replayed,) = world.batches([at])
    fit = {**replayed_fit(MEASURED, replayed, at, {}),
           "jacobian": np.concatenate(world.patterns["tissue_stiffness"])[:, None]}
    before = world.count
    out, _, kept, _ = look.confirmed_second_look(world, MEASURED, ROWS, fit, list(at),
                                                 fit["left"], list(PARAMS.causes), {}, 0.08,
                                                 2)
    return out, kept, world.count - before


def test_a_fit_as_close_to_the_logs_as_its_replays_to_each_other_gets_no_second_look() -> None:
    out, kept, replays = _second_look_on_the_stiffness(ScatteringWorld(BATCH, 1))
    assert kept == ["tissue_stiffness"] and "second_look" not in out
    scatter = out["replay_scatter"]
    assert (1.0 - 0.08) * scatter["median_rmse_N"] <= scatter["floor_N"]
    assert replays == (JITTERS + 1) * len(BATCH.logs)


def test_a_fit_farther_from_the_logs_than_its_replays_scatter_gets_its_second_look() -> None:
    out, kept, _ = _second_look_on_the_stiffness(HidingWorld(BATCH, 1))
    assert kept == ["tissue_stiffness", "tearing_threshold"]
    assert out["replay_scatter"]["floor_N"] < out["replay_scatter"]["median_rmse_N"]


def test_the_report_says_why_no_second_look_was_made() -> None:
    lines = _spread_lines({"replay_scatter": {"median_rmse_N": 0.3, "scatter_N": 0.25,
                                              "noise_N": 0.12, "floor_N": 0.277}})
    assert lines == ["- The fitted world's replays: 0.300 N from the logs (median), 0.250 N "
                     "from each other, the sensors' noise 0.120 N; nothing left for a second "
                     "look"]
    looked = _spread_lines({"replay_scatter": {"median_rmse_N": 0.5, "scatter_N": 0.25,
                                               "noise_N": 0.12, "floor_N": 0.277,
                                               "looked": True}})
    assert looked[0].endswith("; a second look found no cause beside the fit")


def test_a_fit_as_close_to_the_logs_as_their_sensors_noise_gets_no_second_look() -> None:
    world = HidingWorld(BATCH, 1)
    world.noise_rmse_n = 10.0
    out, kept, _ = _second_look_on_the_stiffness(world)
    assert kept == ["tissue_stiffness"] and "second_look" not in out
    assert out["replay_scatter"]["floor_N"] == pytest.approx(10.0, rel=0.01)


class ShortWorld(LinearWorld):
    """A world where a lower tearing threshold acts half like stiffer muscles, and the logs
    were measured with the muscles stiffer alone."""

    truth: ClassVar[dict[str, float]] = {"tissue_stiffness": TRUE_MAGNITUDE}

    def effect(self, world: dict[str, float], log: int) -> np.ndarray:
        shared = self.patterns["tissue_stiffness"][log]
        own = self.patterns["tearing_threshold"][log]
        threshold = world.get("tearing_threshold", 0.0)
        return world.get("tissue_stiffness", 0.0) * shared + threshold * 0.5 * (shared + own)


def _fit_at(world: LinearWorld, at: dict[str, float], *columns: np.ndarray) -> dict:
    """The replayed fit of ``world`` at ``at``, with ``columns`` as its causes' signatures."""
    (replayed,) = world.batches([at])
    return {**replayed_fit(MEASURED, replayed, at, {}), "jacobian": np.stack(columns, axis=1)}


def test_a_cause_that_only_takes_up_what_a_first_fit_left_short_does_not_earn_its_place(
        ) -> None:
    # The muscles held at 60 % of their change, the threshold making up part of the rest: the
    # muscles refitted alone reach the logs, so the threshold is not needed.
    world = ShortWorld(BATCH, 1)
    union = ["tissue_stiffness", "tearing_threshold"]
    shared = np.concatenate(world.patterns["tissue_stiffness"])
    own = np.concatenate(world.patterns["tearing_threshold"])
    moved = _fit_at(world, {"tissue_stiffness": 0.6 * TRUE_MAGNITUDE,
                            "tearing_threshold": 0.8 * TRUE_MAGNITUDE},
                    shared, 0.5 * (shared + own))
    before = world.count
    assert not look.earn_their_place(world, MEASURED, {}, moved, union[:1], union, 0.08, 2)
    # The world less the threshold, then Gauss-Newton's steps, each a replay of every log.
    assert world.count - before == (1 + 2 + 1) * len(BATCH.logs)


def test_a_cause_the_logs_hold_earns_its_place_beside_the_first_fit() -> None:
    world = SharingWorld(BATCH, 1)
    union = ["tissue_stiffness", "tearing_threshold"]
    shared = np.concatenate(world.patterns["tissue_stiffness"])
    own = np.concatenate(world.patterns["tearing_threshold"])
    moved = _fit_at(world, dict(SharingWorld.truth), shared, 2.0 * shared + 0.3 * own)
    assert look.earn_their_place(world, MEASURED, {}, moved, union[:1], union, 0.08, 2)
