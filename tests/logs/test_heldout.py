"""The batch diagnosis of separation logs names a world cause only when it carries from the
logs it was fitted to onto each log left out, and fits a cause whose response flattens as it
grows (cell.logs.diagnosis), on replays that a world of known responses stands in for."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

import cell.logs.diagnosis as logdiagnosis
from cell.logs.batch import LogBatch
from cell.logs.diagnosis import LogDiagnosisParams, diagnose_logs
from cell.logs.fit import logged_vector, rmse_n
from cell.logs.outcome import EVIDENCE_ROWS
from cell.logs.search import from_probes, heldout_replays, mirrored, pruned, replayed_fit
from cell.measure.logs import Channel, SeparationLog
from cell.sim.scenario import Scenario

CAUSES = ("tearing_threshold", "tissue_stiffness")
TRUE_MAGNITUDE = 0.5


def _log(n: int, phase: float) -> SeparationLog:
    t = np.linspace(0.0, 1.0, n)
    wave = np.stack([np.sin(3 * t + phase), np.cos(2 * t), t], axis=1)
    pose = {"position_m": np.zeros((n, 3)), "quaternion": np.tile([1.0, 0, 0, 0], (n, 1))}
    channels = {"knife": Channel(t, wave, **pose), "gripper": Channel(t, 2 * wave, **pose),
                "fixture": Channel(t, wave)}
    return SeparationLog(Path(f"log-{n}"), f"log-{n}", Path("scenario.toml"), 0, channels)


BATCH = LogBatch(tuple(_log(n, 0.1 * n) for n in (60, 50, 40)), (Scenario(),) * 3)


class LinearWorld:
    """Replays of :data:`BATCH` in a world where each cause adds its own pattern times its
    magnitude (times :meth:`response` of it), and the logs were measured at :attr:`truth`;
    the replays' outcomes and releases agree with the logs' (their entries are 0)."""

    truth: ClassVar[dict[str, float]] = {"tearing_threshold": TRUE_MAGNITUDE}

    def __init__(self, batch: LogBatch, workers: int, cluster: object = None) -> None:
        rng = np.random.default_rng(0)
        self.folders = [str(log.folder) for log in batch.logs]
        self.count, self.wall_s, self.cpu_s, self.in_process = 0, 0.0, 0.0, True
        self.weight, self.progress, self.round, self.by_round = 1.0, None, "", {}
        self.batch, self.scales, self.noise_rmse_n = batch, None, 0.0
        measured = [logged_vector([log], EVIDENCE_ROWS)[0] for log in batch.logs]
        forces = [np.arange(m.size) < m.size - EVIDENCE_ROWS for m in measured]
        pairs = list(zip(measured, forces, strict=True))
        self.patterns = {c: [rng.normal(size=m.size) * f for m, f in pairs] for c in CAUSES}
        self.base = [m - self.effect(self.truth, i) - 0.01 * rng.normal(size=m.size) * f
                     for i, (m, f) in enumerate(pairs)]

    @staticmethod
    def response(magnitude: float) -> float:
        return magnitude

    def effect(self, world: dict[str, float], log: int) -> np.ndarray:
        return sum((self.response(m) * self.patterns[c][log] for c, m in world.items()),
                   np.zeros_like(self.patterns[CAUSES[0]][log]))

    def __enter__(self) -> LinearWorld:
        return self

    def __exit__(self, *exc: object) -> None:
        return None

    def run(self, jobs: list[tuple[int, dict[str, float]]]) -> list[np.ndarray]:
        self.count += len(jobs)
        self.by_round[self.round] = self.by_round.get(self.round, 0) + len(jobs)
        return [(self.base[i] + self.effect(world, i)) * (1.0 if self.scales is None
                                                          else self.scales[i])
                for i, world in jobs]

    def batches(self, worlds: list[dict[str, float]]) -> list[np.ndarray]:
        return [np.concatenate(self.run([(i, w) for i in range(len(self.folders))]))
                for w in worlds]


@pytest.fixture
def linear_world(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(logdiagnosis, "Replayer", LinearWorld)


PARAMS = LogDiagnosisParams(workers=1, causes=CAUSES)


def test_a_cause_that_predicts_the_logs_left_out_is_named(linear_world: None) -> None:
    result = diagnose_logs(BATCH, PARAMS).to_json()
    assert result["causes"] == ["tearing_threshold"]
    assert "dropped" not in result["extended"]
    assert result["gain"] > 0.9


def test_a_cause_that_fits_but_predicts_no_log_left_out_is_dropped(
        linear_world: None, monkeypatch: pytest.MonkeyPatch) -> None:
    # The replays of the logs left out miss by twice what the lab's world misses.
    def worse(replayer: Any, measured: np.ndarray, *_: Any) -> np.ndarray:
        return 2.0 * (measured - np.concatenate(replayer.base))

    monkeypatch.setattr(logdiagnosis, "heldout_replays", worse)
    result = diagnose_logs(BATCH, PARAMS).to_json()
    assert result["causes"] == []
    dropped = result["extended"]["dropped"]
    assert dropped["causes"] == ["tearing_threshold"]
    assert dropped["heldout_rmse_N"] > dropped["without_N"]
    assert result["extended"]["params"] == {} and result["gain"] == 0.0


class OneLogWorld(LinearWorld):
    """A world whose tearing threshold shows in the first log alone (the others' bindings are
    far from tearing): the first log's misfit, one tear the lab's world replays without,
    goes with the threshold, which the other logs neither ask for nor mind."""

    def __init__(self, batch: LogBatch, workers: int, cluster: object = None) -> None:
        super().__init__(batch, workers, cluster)
        for pattern in self.patterns["tearing_threshold"][1:]:
            pattern[:] = 0.0


def test_a_log_left_out_keeps_the_lab_s_world_where_the_others_do_not_ask_for_the_change(
        ) -> None:
    world = OneLogWorld(BATCH, 1)
    measured, rows = logged_vector(BATCH.logs, EVIDENCE_ROWS)
    lab = replayed_fit(measured, np.concatenate(world.base), {}, {})
    (changed,) = world.batches([world.truth])
    fit = {**replayed_fit(measured, changed, world.truth, {}),
           "jacobian": np.concatenate(world.patterns["tearing_threshold"])[:, None]}
    left = heldout_replays(world, measured, rows, fit, ["tearing_threshold"], {}, lab,
                           lab["left"], PARAMS.min_heldout_gain, [])
    first = rows.log == 0
    # Fitted on the other two logs, the threshold is where the lab put it: the first log's
    # misfit stands; each other log, left out, is replayed in the world fitted with the first.
    assert np.array_equal(left[first], lab["left"][first])
    assert rmse_n(fit["left"][first]) < 0.1 * rmse_n(lab["left"][first])
    assert world.count == 3 + 2


class FlatteningWorld(LinearWorld):
    """A world whose causes act a tenth as much beyond the screening step (0.4) as within
    it, as a turned fibre's or a stiffer muscle's flatten."""

    @staticmethod
    def response(magnitude: float) -> float:
        size = abs(magnitude)
        return float(np.sign(magnitude)) * (size if size <= 0.4 else 0.4 + 0.1 * (size - 0.4))


def test_a_cause_whose_response_flattens_is_fitted_past_its_linear_estimate(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(logdiagnosis, "Replayer", FlatteningWorld)
    # No Gauss-Newton step after the first: the screening's secant alone stops 18 % short.
    result = diagnose_logs(BATCH, replace(PARAMS, newton_steps=0)).to_json()
    assert result["causes"] == ["tearing_threshold"]
    fitted = result["extended"]["params"]["tearing_threshold"]["magnitude"]
    assert fitted == pytest.approx(TRUE_MAGNITUDE, rel=0.1)


class TwoCauseFlatteningWorld(FlatteningWorld):
    """:class:`FlatteningWorld` measured with a second cause, one within the screening step."""

    truth: ClassVar[dict[str, float]] = {"tearing_threshold": TRUE_MAGNITUDE,
                                         "tissue_stiffness": 0.3}


def test_causes_that_stop_short_by_different_shares_are_each_fitted_past_their_estimate(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(logdiagnosis, "Replayer", TwoCauseFlatteningWorld)
    # The secant stops 18 % short on the tearing threshold and not on the stiffness: stretched
    # together, the stiffness would overshoot as much as the threshold gained.
    result = diagnose_logs(BATCH, replace(PARAMS, newton_steps=0)).to_json()
    assert sorted(result["causes"]) == sorted(TwoCauseFlatteningWorld.truth)
    for cause, truth in TwoCauseFlatteningWorld.truth.items():
        fitted = result["extended"]["params"][cause]["magnitude"]
        assert fitted == pytest.approx(truth, rel=0.1)


class HidingWorld(LinearWorld):
    """A world where the bindings tear otherwise only under stiffer muscles: the tearing
    threshold's pattern scales with the stiffness' magnitude (none in the lab's world), and
    the logs were measured with both changed."""

    truth: ClassVar[dict[str, float]] = {"tissue_stiffness": TRUE_MAGNITUDE,
                                         "tearing_threshold": TRUE_MAGNITUDE}

    def effect(self, world: dict[str, float], log: int) -> np.ndarray:
        stiffness = world.get("tissue_stiffness", 0.0)
        return (stiffness * self.patterns["tissue_stiffness"][log] + stiffness
                * world.get("tearing_threshold", 0.0) * self.patterns["tearing_threshold"][log])


def test_a_cause_that_shows_only_beside_another_is_named_at_a_second_look(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(logdiagnosis, "Replayer", HidingWorld)
    result = diagnose_logs(BATCH, PARAMS).to_json()
    assert result["causes"] == ["tissue_stiffness", "tearing_threshold"]
    assert [step["round"] for step in result["steps"] if step["added"]] == [1, 2]
    assert result["extended"]["second_look"]["kept"]
    for cause in HidingWorld.truth:
        fitted = result["extended"]["params"][cause]["magnitude"]
        assert fitted == pytest.approx(TRUE_MAGNITUDE, rel=0.05)


def test_a_single_cause_is_not_joined_by_another_at_the_second_look(linear_world: None) -> None:
    result = diagnose_logs(BATCH, PARAMS).to_json()
    assert result["causes"] == ["tearing_threshold"]
    assert "second_look" not in result["extended"]


class TurnedWorld(LinearWorld):
    """A world where the fibres turned either way act nearly alike: the square of the angle
    on one pattern, a small uneven part on another; the logs measured with them turned
    -0.9 rad."""

    truth: ClassVar[dict[str, float]] = {"fibre_direction": -0.9}

    def effect(self, world: dict[str, float], log: int) -> np.ndarray:
        angle = world.get("fibre_direction", 0.0)
        return (angle ** 2 * self.patterns["tearing_threshold"][log]
                + 0.2 * angle * self.patterns["tissue_stiffness"][log])


def test_an_angle_fitted_on_the_wrong_side_is_turned_the_other_way() -> None:
    world = TurnedWorld(BATCH, 1)
    measured, _ = logged_vector(list(BATCH.logs), EVIDENCE_ROWS)
    wrong, nearer = world.batches([{"fibre_direction": 0.9}, {"fibre_direction": 0.5}])
    fit = {**replayed_fit(measured, wrong, {"fibre_direction": 0.9}, {}),
           "jacobian": ((wrong - nearer) / 0.4)[:, None]}
    turned = mirrored(world, measured, {}, fit, ["fibre_direction"], steps=2)
    assert turned["magnitudes"]["fibre_direction"] == pytest.approx(-0.9, rel=0.02)
    assert rmse_n(turned["left"]) < 0.1 * rmse_n(fit["left"])


def test_a_fit_that_ends_farther_than_a_screening_replay_starts_again_from_it() -> None:
    """Near no turn the fibres' effect is nearly even in the angle: a fit that stopped there
    has no slope to follow, and the screening's replay near the turn is closer."""
    world = TurnedWorld(BATCH, 1)
    measured, _ = logged_vector(list(BATCH.logs), EVIDENCE_ROWS)
    stuck, lab = world.batches([{"fibre_direction": -0.05}, {}])
    fit = replayed_fit(measured, stuck, {"fibre_direction": -0.05}, {})
    slope = ((stuck - lab) / -0.05)[:, None]
    again = from_probes(world, measured, {}, fit, ["fibre_direction"], slope, steps=4)
    assert again["magnitudes"]["fibre_direction"] == pytest.approx(-0.9, rel=0.05)
    assert rmse_n(again["left"]) < 0.1 * rmse_n(fit["left"])
    assert again["jacobian"].shape == slope.shape  # the held-out replays step with it


def test_a_fit_as_close_as_every_screening_replay_stands() -> None:
    world = TurnedWorld(BATCH, 1)
    measured, _ = logged_vector(list(BATCH.logs), EVIDENCE_ROWS)
    (near,) = world.batches([TurnedWorld.truth])
    fit = replayed_fit(measured, near, dict(TurnedWorld.truth), {})
    assert from_probes(world, measured, {}, fit, ["fibre_direction"], near[:, None],
                       steps=2) is fit


def _fitted_at(world: LinearWorld, at: dict[str, float]) -> tuple[np.ndarray, dict[str, Any]]:
    """The logged vector and a fit of ``world`` replayed at ``at``, the causes' own patterns
    its signatures."""
    measured, _ = logged_vector(list(BATCH.logs), EVIDENCE_ROWS)
    (replayed,) = world.batches([at])
    signatures = np.stack([np.concatenate(world.patterns[c]) for c in at], axis=1)
    return measured, {**replayed_fit(measured, replayed, at, {}), "jacobian": signatures}


def test_a_cause_that_does_not_earn_its_place_in_the_replays_is_left_out() -> None:
    """The fit handed a sliver of the threshold's effect to a muscle a little stiffer: without
    it the replays fit as well, so it goes, its signature with it."""
    world = LinearWorld(BATCH, 1)
    at = {"tearing_threshold": 0.49, "tissue_stiffness": 0.004}
    measured, fit = _fitted_at(world, at)
    kept, causes = pruned(world, measured, {}, fit, list(at), PARAMS.min_heldout_gain, 2)
    assert causes == ["tearing_threshold"]
    assert kept["magnitudes"]["tearing_threshold"] == pytest.approx(TRUE_MAGNITUDE, rel=0.02)
    assert kept["jacobian"].shape == (measured.size, 1)
    assert [gone["cause"] for gone in kept["pruned"]] == ["tissue_stiffness"]


class MakingUpWorld(LinearWorld):
    """A world whose stiffer muscles make up for part of a threshold fitted short: the
    stiffness' pattern is a share of the threshold's, and a fit that stopped short of the
    threshold fits better with the stiffness than without it, though the threshold alone,
    fitted again, fits best."""

    def __init__(self, batch: LogBatch, workers: int, cluster: object = None) -> None:
        super().__init__(batch, workers, cluster)
        self.patterns["tissue_stiffness"] = [0.8 * threshold + 0.2 * other for threshold, other
                                             in zip(self.patterns["tearing_threshold"],
                                                    self.patterns["tissue_stiffness"],
                                                    strict=True)]


def test_causes_that_make_up_for_each_other_are_fitted_again_without_the_one_not_needed(
        ) -> None:
    world = MakingUpWorld(BATCH, 1)
    at = {"tearing_threshold": 0.3, "tissue_stiffness": 0.2}
    measured, fit = _fitted_at(world, at)
    (alone,) = world.batches([{"tearing_threshold": 0.3}])
    # Taken out without a fit, the stiffness looks needed: the threshold stopped short.
    assert rmse_n(measured - alone) > 2 * rmse_n(fit["left"])
    kept, causes = pruned(world, measured, {}, fit, list(at), PARAMS.min_heldout_gain, 2)
    assert causes == ["tearing_threshold"]
    assert kept["magnitudes"]["tearing_threshold"] == pytest.approx(TRUE_MAGNITUDE, rel=0.02)


class StandInWorld(LinearWorld):
    """A world measured with two causes where a third, the bindings' gradient, stands in for
    most of the stiffness: its pattern is a share of the stiffness' and a little of its own."""

    truth: ClassVar[dict[str, float]] = {"tearing_threshold": TRUE_MAGNITUDE,
                                         "tissue_stiffness": TRUE_MAGNITUDE}

    def __init__(self, batch: LogBatch, workers: int, cluster: object = None) -> None:
        rng = np.random.default_rng(1)
        super().__init__(batch, workers, cluster)
        self.patterns["binding_gradient"] = [
            0.8 * stiffness + 0.2 * rng.normal(size=stiffness.size) * (stiffness != 0)
            for stiffness in self.patterns["tissue_stiffness"]]


def test_a_cause_standing_in_for_another_goes_though_it_looks_needed_most() -> None:
    world = StandInWorld(BATCH, 1)
    at = {"tearing_threshold": TRUE_MAGNITUDE, "tissue_stiffness": 0.2, "binding_gradient": 0.375}
    measured, fit = _fitted_at(world, at)
    # Taken out without a fit, the stiffness costs least: the gradient makes up for it.
    without = [rmse_n(measured - world.batches([{c: m for c, m in at.items() if c != gone}])[0])
               for gone in at]
    assert int(np.argmin(without)) == list(at).index("tissue_stiffness")
    kept, causes = pruned(world, measured, {}, fit, list(at), PARAMS.min_heldout_gain, 2)
    assert causes == ["tearing_threshold", "tissue_stiffness"]
    assert [gone["cause"] for gone in kept["pruned"]] == ["binding_gradient"]
    for cause in causes:
        assert kept["magnitudes"][cause] == pytest.approx(TRUE_MAGNITUDE, rel=0.02)


def test_causes_the_replays_need_are_all_kept() -> None:
    world = TwoCauseFlatteningWorld(BATCH, 1)
    at = dict(TwoCauseFlatteningWorld.truth)
    measured, fit = _fitted_at(world, at)
    kept, causes = pruned(world, measured, {}, fit, list(at), PARAMS.min_heldout_gain, 2)
    assert kept is fit and causes == list(at)


class EitherWorld(LinearWorld):
    """A world measured with the threshold alone, where stiffer muscles act all but alike:
    their pattern is the threshold's and, a third of the noise's size, one of their own."""

    def __init__(self, batch: LogBatch, workers: int, cluster: object = None) -> None:
        super().__init__(batch, workers, cluster)
        share = 0.3 * 0.01 / TRUE_MAGNITUDE
        self.patterns["tissue_stiffness"] = [
            threshold + share * other for threshold, other
            in zip(self.patterns["tearing_threshold"], self.patterns["tissue_stiffness"],
                   strict=True)]


def test_of_two_causes_either_of_which_could_go_the_one_that_fits_closer_alone_stays() -> None:
    world = EitherWorld(BATCH, 1)
    at = {"tearing_threshold": 0.2 * TRUE_MAGNITUDE, "tissue_stiffness": 0.8 * TRUE_MAGNITUDE}
    measured, fit = _fitted_at(world, at)
    # Taken out without a refit, the threshold costs least, and the muscles alone, refitted,
    # come within the bar as well: the threshold alone comes closer.
    without = [rmse_n(measured - world.batches([{c: m for c, m in at.items() if c != gone}])[0])
               for gone in at]
    assert int(np.argmin(without)) == list(at).index("tearing_threshold")
    kept, causes = pruned(world, measured, {}, fit, list(at), PARAMS.min_heldout_gain, 2)
    assert causes == ["tearing_threshold"]
    assert kept["magnitudes"]["tearing_threshold"] == pytest.approx(TRUE_MAGNITUDE, rel=0.02)


def test_the_refits_without_each_cause_replay_side_by_side() -> None:
    world = TwoCauseFlatteningWorld(BATCH, 1)
    at = dict(TwoCauseFlatteningWorld.truth)
    measured, fit = _fitted_at(world, at)
    asked = []
    replay = world.batches
    world.batches = lambda worlds: asked.append(len(worlds)) or replay(worlds)
    pruned(world, measured, {}, fit, list(at), PARAMS.min_heldout_gain, 2)
    # The world less each cause, then each of Gauss-Newton's steps for both refits at once.
    assert asked == [2, 2, 2, 2]
