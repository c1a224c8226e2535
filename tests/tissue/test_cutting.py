"""The edge's cutting resistance: against the edge's advance, balanced by the tissue, no residue."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from cell.sim.assembly import build_scene
from cell.sim.scenario import Scenario
from cell.tissue.cutting import REACTION_VERTICES, EdgeResistance
from cell.tissue.geometry import MuscleShape

HALF = np.array([0.0125, 0.0005, 0.1])


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return build_scene(Scenario(tissue=MuscleShape(cell_size_m=0.05)), robots=False).model


@pytest.fixture
def data(model: mujoco.MjModel) -> mujoco.MjData:
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return data


def test_resistance_opposes_the_edge_and_fades_when_it_stands(
        model: mujoco.MjModel, data: mujoco.MjData) -> None:
    edge = EdgeResistance(model)
    centre = data.flexvert_xpos.mean(axis=0)
    back, _ = edge.apply(data, 10.0, centre, np.eye(3), HALF, np.array([-0.03, 0.0, 0.0]))
    assert back[0] == pytest.approx(10.0, rel=1e-3)  # against the motion, like friction
    still, moment = edge.apply(data, 10.0, centre, np.eye(3), HALF, np.zeros(3))
    assert not still.any() and not moment.any()
    assert not data.xfrc_applied.any()  # the reaction is taken back too


def test_reaction_lands_on_the_vertices_nearest_the_edge_and_keeps_other_loads(
        model: mujoco.MjModel, data: mujoco.MjData) -> None:
    edge = EdgeResistance(model)
    centre = data.flexvert_xpos.mean(axis=0)
    other = model.flex_vertbodyid[np.flatnonzero(model.body_dofnum[model.flex_vertbodyid] == 3)]
    data.xfrc_applied[other[0], 2] = 1.0  # someone else's load
    force, _ = edge.apply(data, 4.0, centre, np.eye(3), HALF, np.array([0.03, 0.0, 0.0]))
    loaded = np.flatnonzero(data.xfrc_applied[:, 0])
    assert len(loaded) == REACTION_VERTICES
    np.testing.assert_allclose(data.xfrc_applied[:, :3].sum(axis=0), -force + [0, 0, 1.0])
    edge.apply(data, 0.0, centre, np.eye(3), HALF, np.zeros(3))
    assert data.xfrc_applied[other[0], 2] == 1.0
    assert np.count_nonzero(data.xfrc_applied) == 1


def test_a_load_on_the_edge_and_faces_puts_its_reaction_on_the_tissue(
        model: mujoco.MjModel, data: mujoco.MjData) -> None:
    edge = EdgeResistance(model)
    centre = data.flexvert_xpos.mean(axis=0)
    on_blade = np.array([-8.0, 0.5, 1.2])  # an edge's and faces' load, as the seam gives it
    edge.load(data, on_blade, centre, np.eye(3), HALF)
    assert len(np.flatnonzero(data.xfrc_applied[:, 0])) == REACTION_VERTICES
    np.testing.assert_allclose(data.xfrc_applied[:, :3].sum(axis=0), -on_blade)
    edge.load(data, np.zeros(3), centre, np.eye(3), HALF)
    assert not data.xfrc_applied.any()
