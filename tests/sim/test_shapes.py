"""Any shape within the documented ranges runs with the default scenario: ten drawn (seeds
9000-9009, which neither the tuning, 1000 on, nor the bench, 5000 on, uses) build, are seen
and planned, the knife's planned tip at the table's clearance along the whole valley. How
close it keeps to the true interface is the bench's (``musclecell bench perception --shapes
N``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from cell.bench.shapes import documented_shape
from cell.errors import InputError
from cell.robots.camera import CameraRig
from cell.robots.names import CAMERA
from cell.sim.assembly import build_scene
from cell.sim.episode import Episode
from cell.sim.scenario import Scenario, load_scenario
from cell.tissue.geometry import MuscleShape
from tests.marks import slow_but
from tests.paths import DEFAULT_SCENARIO

SEEDS = range(9000, 9010)


@pytest.fixture(scope="module")
def default() -> Scenario:
    return load_scenario(DEFAULT_SCENARIO)


# Three shapes in the default run, all ten with ``-m slow``: a shape's build and look take
# seconds.
@pytest.mark.parametrize("seed", slow_but(SEEDS[:3], SEEDS))
def test_a_documented_shape_builds_is_seen_and_planned(default: Scenario, seed: int) -> None:
    # Nothing but the shape changes: the derived values and the implicit step follow it.
    scenario = replace(default, tissue=documented_shape(seed, default.tissue))
    scene = build_scene(scenario)
    episode = Episode(scenario, scene)
    with CameraRig(scene.model, CAMERA, scenario.camera.width_px,
                   scenario.camera.height_px) as rig:
        perceived = episode.perceive(rig)
    plan = episode.plan(perceived)
    table_z = scenario.layout.table_height_m
    path = plan.cut_path_m
    # Down to the clearance all along, however tall the meat: the lowest bindings lie on the
    # table. Along the whole valley: the cut ends where the guideline does.
    np.testing.assert_allclose(path[:, 2], table_z + scenario.cut.table_clearance_m)
    assert perceived.coverage >= 0.9
    assert plan.cut_window_s.start_s < plan.cut_window_s.end_s < plan.end_s


def test_the_valley_width_follows_a_taller_round_and_a_given_one_is_still_checked() -> None:
    taller = MuscleShape(round_height_m=0.13)  # the default 0.03 m would make 45-degree walls
    assert taller.valley_decay_m > 0.03
    assert MuscleShape().valley_decay_m == 0.03
    with pytest.raises(InputError) as refused:
        replace(taller, valley_width_m=0.03)
    assert refused.value.field == "valley_width_m"
