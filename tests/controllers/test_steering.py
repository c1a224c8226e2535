"""The blade steered by what it feels: the knife's lateral load corrects the interface's lean
below the guideline, only where the load tells it, and never past its bound."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from controllers.steering import LeanSteering, SteeringParams

GUIDELINE = np.array([[-0.2, 0.0, 0.66], [0.0, 0.0, 0.67], [0.2, 0.0, 0.66]])
TOWARDS_PLUS_Y = np.array([0.0, 3.0, 0.0])  # N: the flesh pushes the blade to +y
PULLED_TO_PLUS_Y = np.array([0.0, 1.0, 0.6])  # the gripper's pull direction


def _steered(params: SteeringParams, target_m: np.ndarray, load_n: np.ndarray,
             steps: int = 100) -> tuple[LeanSteering, np.ndarray]:
    steering = LeanSteering(params, GUIDELINE, PULLED_TO_PLUS_Y)
    position = target_m
    for _ in range(steps):
        position, _ = steering.correct((target_m, np.eye(3)), load_n, 0.02)
    return steering, position


def test_a_blade_pushed_towards_plus_y_is_steered_there_the_more_the_deeper() -> None:
    steering, shallow = _steered(SteeringParams(), np.array([0.0, 0.0, 0.64]), TOWARDS_PLUS_Y)
    assert steering.lean_change < 0.0
    assert shallow[1] > 0.0
    deep, _ = steering.correct((np.array([0.0, 0.0, 0.60]), np.eye(3)), TOWARDS_PLUS_Y, 0.02)
    assert deep[1] > shallow[1]  # the lean's correction grows with depth below the top


def test_the_load_of_a_blade_on_the_interface_changes_nothing() -> None:
    params = SteeringParams()
    on_interface = np.array([0.0, params.on_interface_load_n + 0.5 * params.dead_band_n, 0.0])
    steering, position = _steered(params, np.array([0.0, 0.0, 0.60]), on_interface)
    assert steering.lean_change == 0.0 and position[1] == 0.0


@pytest.mark.parametrize("target_m", [np.array([0.0, 0.0, 0.665]),  # 5 mm deep
                                      np.array([0.19, 0.0, 0.60])],  # near the meat's end
                         ids=["shallow", "near-the-end"])
def test_it_learns_nothing_where_the_load_does_not_tell_the_lean(target_m: np.ndarray) -> None:
    steering, _ = _steered(SteeringParams(), target_m, TOWARDS_PLUS_Y)
    assert steering.lean_change == 0.0


def test_the_correction_stops_at_its_bound_and_a_push_the_other_way_brings_it_back() -> None:
    params = SteeringParams(max_lean_change=0.05)
    steering, _ = _steered(params, np.array([0.0, 0.0, 0.60]), 10 * TOWARDS_PLUS_Y, steps=2000)
    assert steering.lean_change == pytest.approx(-0.05)
    for _ in range(200):
        steering.correct((np.array([0.0, 0.0, 0.60]), np.eye(3)), -TOWARDS_PLUS_Y, 0.02)
    assert steering.lean_change > -0.05
    assert steering.extremes[0] == pytest.approx(-0.05)


def test_disabled_steering_keeps_the_planned_target() -> None:
    target = np.array([0.0, 0.0, 0.60])
    steering, position = _steered(replace(SteeringParams(), enabled=False), target,
                                  TOWARDS_PLUS_Y)
    assert steering.lean_change == 0.0 and np.array_equal(position, target)


def test_it_steers_the_same_way_whichever_end_the_cut_starts_from() -> None:
    target = np.array([0.0, 0.0, 0.60])
    steered = []
    for guideline in (GUIDELINE, GUIDELINE[::-1]):
        steering = LeanSteering(SteeringParams(), guideline, PULLED_TO_PLUS_Y)
        for _ in range(100):
            position, _ = steering.correct((target, np.eye(3)), TOWARDS_PLUS_Y, 0.02)
        steered.append((position[1], steering.lean_change))
    assert steered[0] == pytest.approx(steered[1])
    assert steered[0][0] > 0.0 and steered[0][1] < 0.0  # the lean of y = ... + lean * z


def test_a_blade_on_the_pulled_muscles_side_which_pushes_back_less_is_steered_back_harder(
        ) -> None:
    params = SteeringParams()
    target = np.array([0.0, 0.0, 0.60])
    beyond_n = params.dead_band_n + 1.0
    changes = {}
    for side, sign in (("pulled", -1.0), ("other", 1.0)):  # the load points away from the tip
        load = np.array([0.0, params.on_interface_load_n + sign * beyond_n, 0.0])
        steering, _ = _steered(params, target, load, steps=10)
        changes[side] = steering.lean_change
    assert changes["pulled"] > 0.0 > changes["other"]
    assert changes["pulled"] == pytest.approx(-params.pulled_side_gain * changes["other"],
                                              rel=0.05)


def test_a_blade_lifted_by_the_unpulled_muscle_goes_to_the_pulled_side_whatever_it_feels_across(
        ) -> None:
    # Tuning seed 9004: 5 mm into the muscle that is not pulled, the load across read -0.4 to
    # -1.3 N, as if the tip were on the pulled side, while the flesh lifted the blade 2-4 N.
    params = SteeringParams()
    target = np.array([0.0, 0.0, 0.60])
    read_as_pulled_side = np.array([0.0, -1.0, 0.0])
    lifted = np.array([0.0, -1.0, params.in_flesh_lift_n + 2.0])  # and lifted
    steering, position = _steered(params, target, lifted)
    assert steering.lean_change < 0.0 and position[1] > 0.0  # towards the pulled side (+y)
    unlifted, _ = _steered(params, target, read_as_pulled_side)
    assert unlifted.lean_change > 0.0  # without the lift it reads the pulled side's load
    assert steering.lift_n == pytest.approx(params.in_flesh_lift_n + 2.0, rel=0.01)
