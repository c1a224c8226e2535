"""The cut scored against the true interface: the tip's distance, the flesh the blade sweeps,
the bindings it missed."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from cell.sim.assembly import Scene, build_scene
from cell.sim.scenario import Scenario
from cell.sim.score import CutScore
from cell.tissue.geometry import MuscleShape

DOWN = np.array([0.0, 0.0, 1.0])  # the tool's z points down to the tip


@pytest.fixture(scope="module")
def scene() -> Scene:
    return build_scene(Scenario(tissue=MuscleShape(cell_size_m=0.05)), robots=False)


@pytest.fixture
def data(scene: Scene) -> mujoco.MjData:
    data = mujoco.MjData(scene.model)
    scene.restore(data)
    mujoco.mj_forward(scene.model, data)
    return data


def _score(scene: Scene, blade_length_m: float = 0.01) -> CutScore:
    return CutScore(scene.aponeurosis, scene.mesh, blade_length_m, blade_thickness_m=0.001)


def _on_interface(scene: Scene, x_m: float, below_top_m: float) -> np.ndarray:
    mesh = scene.mesh
    top_z = float(np.interp(x_m, mesh.top_line[:, 0], mesh.top_line[:, 2]))
    z = top_z - below_top_m
    return np.array([x_m, float(mesh.interface_y(np.array(x_m), np.array(z))), z])


def test_a_tip_on_the_interface_is_on_it_and_one_off_it_is_as_far(
        scene: Scene, data: mujoco.MjData) -> None:
    score = _score(scene)
    score.observe(data, 0, _on_interface(scene, 0.0, 0.03), DOWN)
    score.observe(data, 1, _on_interface(scene, 0.02, 0.03) + np.array([0.0, 0.008, 0.0]), DOWN)
    tip = score.tip_distance()
    first, second = tip["passes"]
    assert first["mean"] < 5e-4
    # The interface leans 0.1: 8 mm along y is 8 cos(atan 0.1) mm from it.
    assert second["mean"] == pytest.approx(0.008 * np.cos(np.arctan(0.1)), abs=5e-4)
    assert tip["max"] == second["max"] and tip["samples"] == 2


def test_the_tip_outside_the_meat_is_not_scored(scene: Scene, data: mujoco.MjData) -> None:
    score = _score(scene)
    beyond = _on_interface(scene, scene.mesh.top_line[0, 0], 0.03) - [0.03, 0.0, 0.0]
    score.observe(data, 0, beyond, DOWN)
    assert score.tip_distance()["samples"] == 0


def test_a_blade_off_the_interface_sweeps_flesh_one_along_it_none(
        scene: Scene, data: mujoco.MjData) -> None:
    along, off = _score(scene), _score(scene)
    for x_m in (0.0, 0.01, 0.02):
        # A short blade, so that the interface's lean keeps it within the gap.
        along.observe(data, 0, _on_interface(scene, x_m, 0.03), DOWN)
        off.observe(data, 0, _on_interface(scene, x_m, 0.03) + np.array([0.0, 0.01, 0.0]), DOWN)
    assert along.flesh_damage()["blade_area_in_flesh_m2"] == 0.0
    swept = off.flesh_damage()
    # The whole 1 cm edge in flesh over 2 cm of advance.
    assert swept["blade_area_in_flesh_m2"] == pytest.approx(0.01 * 0.02, rel=0.01)
    assert swept["blade_volume_in_flesh_m3"] == pytest.approx(0.01 * 0.02 * 0.001, rel=0.01)


def test_bindings_nothing_cut_are_all_missed_and_left(scene: Scene,
                                                      data: mujoco.MjData) -> None:
    damage = _score(scene).flesh_damage()
    bindings = len(scene.aponeurosis)
    assert damage["bindings_missed"] == damage["bindings_left"] == bindings
    assert damage["bindings_torn"] == 0 and damage["missed_fraction"] == 1.0
