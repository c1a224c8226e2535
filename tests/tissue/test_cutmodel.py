"""The cutting model's force law (cell.tissue.cutmodel) and its [cutting] table."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cell.errors import MaterialError
from cell.tissue.cutmodel import (
    CuttingParams,
    beef_cutting,
    edge_force,
    face_friction_force,
    push_and_slice,
)
from cell.tissue.material import default_meat
from cell.tissue.materialfile import load_material, material_to_toml

DOWN = np.array([0.0, 0.0, -0.01])
NO_SLICE = np.zeros(3)
ALONG = np.array([0.0, 1.0, 0.0])


def test_a_push_cut_costs_the_toughness_per_unit_length_of_edge() -> None:
    params = CuttingParams(toughness_j_m2=900.0)
    force = edge_force(params, 0.05, DOWN, NO_SLICE, 0.01)
    np.testing.assert_allclose(force, [0.0, 0.0, 45.0])


def test_the_edge_force_scales_with_the_engaged_length() -> None:
    params = beef_cutting()
    lengths = np.array([0.01, 0.02, 0.04])
    forces = edge_force(params, lengths, np.tile(DOWN, (3, 1)), np.zeros((3, 3)), 0.01)
    np.testing.assert_allclose(forces[:, 2] / lengths, forces[0, 2] / lengths[0])
    assert edge_force(params, 0.0, DOWN, NO_SLICE, 0.01).tolist() == [0.0, 0.0, 0.0]


def test_no_slicing_factor_at_zero_slice_push_ratio() -> None:
    sliced = CuttingParams(1000.0, slicing_efficiency=2.0)
    plain = CuttingParams(1000.0)
    np.testing.assert_allclose(edge_force(sliced, 0.03, DOWN, NO_SLICE, 0.01),
                               edge_force(plain, 0.03, DOWN, NO_SLICE, 0.01))


@pytest.mark.parametrize("xi", [0.5, 1.0, 3.0])
def test_the_atkins_factor_lowers_the_force_to_sink_the_edge(xi: float) -> None:
    params = CuttingParams(1000.0, slicing_efficiency=1.0)
    force = edge_force(params, 0.04, DOWN, xi * 0.01 * ALONG, 0.01)
    assert force[2] == pytest.approx(40.0 / math.sqrt(1.0 + xi**2))


@pytest.mark.parametrize("eta, xi", [(0.5, 2.0), (1.0, 1.0), (2.0, 0.3)])
def test_the_edge_does_the_fracture_work_whatever_the_slicing(eta: float, xi: float) -> None:
    params = CuttingParams(1000.0, slicing_efficiency=eta)
    slide = xi * 0.01 * ALONG
    force = edge_force(params, 0.04, DOWN, slide, 0.01)
    power = -float(force @ (DOWN + slide))
    assert power == pytest.approx(1000.0 * 0.04 * 0.01)


def test_slicing_does_not_change_a_material_with_no_slicing_efficiency() -> None:
    force = edge_force(CuttingParams(1000.0), 0.04, DOWN, 0.05 * ALONG, 0.01)
    np.testing.assert_allclose(force, [0.0, 0.0, 40.0], atol=1e-12)


def test_the_rate_factor_is_one_at_the_reference_speed() -> None:
    params = CuttingParams(1000.0, reference_speed_m_s=0.01, rate_exponent=0.4)
    assert edge_force(params, 0.04, DOWN, NO_SLICE, 0.01)[2] == pytest.approx(40.0)
    faster = edge_force(params, 0.04, 4 * DOWN, NO_SLICE, 0.01)[2]
    assert faster == pytest.approx(40.0 * 4**0.4)


def test_layers_and_the_indentation_ramp_scale_the_toughness() -> None:
    params = CuttingParams(1000.0, layer_depths_m=(0.01, 0.02), layer_factors=(1.0, 3.0, 0.5),
                           indentation_depth_m=0.004)
    depths = np.array([0.002, 0.008, 0.015, 0.025])
    forces = edge_force(params, 0.01, np.tile(DOWN, (4, 1)), np.zeros((4, 3)), depths)
    np.testing.assert_allclose(forces[:, 2], [5.0, 10.0, 30.0, 5.0])


def test_no_edge_force_when_the_edge_does_not_advance() -> None:
    assert edge_force(beef_cutting(), 0.04, NO_SLICE, NO_SLICE, 0.01).tolist() == [0.0] * 3


@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_face_friction_opposes_the_velocity_also_moving_back(direction: float) -> None:
    params = CuttingParams(1000.0, face_friction=0.3, face_pressure_pa=2000.0)
    velocity = direction * np.array([0.0, 0.0, 0.02])
    force = face_friction_force(params, 1e-3, velocity, NO_SLICE)
    np.testing.assert_allclose(force, [0.0, 0.0, -direction * 2 * 0.3 * 2000.0 * 1e-3])
    sawing = face_friction_force(params, 1e-3, NO_SLICE, direction * 0.05 * ALONG)
    assert sawing[1] * direction < 0
    assert np.linalg.norm(sawing) == pytest.approx(1.2)


def test_face_friction_fades_to_zero_at_rest() -> None:
    params = CuttingParams(1000.0, face_friction=0.3, face_pressure_pa=2000.0)
    assert face_friction_force(params, 1e-3, NO_SLICE, NO_SLICE).tolist() == [0.0] * 3


def test_push_and_slice_split_the_velocity_in_the_blades_plane() -> None:
    push, slide = push_and_slice([[0.001, 0.02, -0.01]], ALONG, [1.0, 0.0, 0.0])
    np.testing.assert_allclose(push, [[0.0, 0.0, -0.01]])
    np.testing.assert_allclose(slide, [[0.0, 0.02, 0.0]])


@pytest.mark.parametrize("fields, key", [
    ({"toughness_j_m2": 0.0}, "toughness_j_m2"),
    ({"toughness_j_m2": math.nan}, "toughness_j_m2"),
    ({"face_friction": -0.1}, "face_friction"),
    ({"rate_exponent": 2.0}, "rate_exponent"),
    ({"reference_speed_m_s": 0.0}, "reference_speed_m_s"),
    ({"layer_depths_m": (0.02, 0.01), "layer_factors": (1.0, 1.0, 1.0)}, "layer_depths_m"),
    ({"layer_depths_m": (0.01,), "layer_factors": (1.0,)}, "layer_factors"),
    ({"layer_depths_m": (0.01,), "layer_factors": (1.0, 0.0)}, "layer_factors"),
])
def test_bad_parameters_name_their_key(fields: dict, key: str) -> None:
    with pytest.raises(MaterialError) as caught:
        replace(CuttingParams(1000.0), **fields)
    assert caught.value.field == key


def test_the_default_beef_reads_its_cutting_table() -> None:
    material = load_material("assets/materials/beef_default.toml")
    assert material.cutting == beef_cutting() == default_meat().cutting


def test_a_cutting_table_is_written_and_read_back(tmp_path: Path) -> None:
    cutting = CuttingParams(700.0, face_friction=0.2, face_pressure_pa=900.0,
                            layer_depths_m=(0.01,), layer_factors=(1.0, 2.5))
    material = replace(default_meat(), cutting=cutting)
    path = tmp_path / "m.toml"
    path.write_text(material_to_toml(material))
    assert load_material(path) == material


def test_a_material_without_a_cutting_table_has_none(tmp_path: Path) -> None:
    path = tmp_path / "m.toml"
    path.write_text('model = "continuum"\nyoung_pa = 4e4\n')
    assert load_material(path).cutting is None


@pytest.mark.parametrize("text, key", [
    ("[cutting]\ntoughness_j_m2 = -5.0\n", "cutting.toughness_j_m2"),
    ("[cutting]\ntoughness_j_m2 = 800.0\nsharpness = 1.0\n", "cutting.sharpness"),
    ("[cutting]\nface_friction = 0.2\n", "cutting.toughness_j_m2"),
    ("cutting = 3.0\n", "cutting"),
])
def test_a_bad_cutting_table_names_file_and_key(tmp_path: Path, text: str, key: str) -> None:
    path = tmp_path / "m.toml"
    path.write_text('model = "continuum"\nyoung_pa = 4e4\n' + text)
    with pytest.raises(MaterialError) as caught:
        load_material(path)
    assert caught.value.field == key
    assert caught.value.file == str(path)
