"""Fitting the generic model's twelve parameters to a cloud of its visible top, and what the
fit predicts about the hidden interface."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from cell.errors import PerceptionError
from cell.perception.registration import (
    AffineFit,
    closest_on_triangles,
    fit_generic_model,
    model_surface,
    predict_interface,
)
from cell.tissue.geometry import MuscleShape, TwoMuscleMesh, build_two_muscles

TABLE_Z_M = 0.6


@pytest.fixture(scope="module")
def model() -> TwoMuscleMesh:
    return build_two_muscles(MuscleShape(), origin_m=(0.0, 0.0, TABLE_Z_M))


@pytest.fixture(scope="module")
def top_points(model: TwoMuscleMesh) -> np.ndarray:
    """2000 points spread over the model's upward-facing triangles: what a camera above sees."""
    surface = model_surface(model)
    normals = surface.triangle_normals()
    areas = np.linalg.norm(normals, axis=1)
    up = np.flatnonzero(normals[:, 2] > 0.2 * areas)
    rng = np.random.default_rng(0)
    picked = rng.choice(up, 2000, p=areas[up] / areas[up].sum())
    a, b, c = np.moveaxis(surface.vertices_m[surface.triangles[picked]], 1, 0)
    r1, r2 = np.sqrt(rng.random((1, 2000))), rng.random((1, 2000))
    return ((1 - r1) * a.T + r1 * (1 - r2) * b.T + r1 * r2 * c.T).T


def _random_transform(rng: np.random.Generator, pivot: np.ndarray) -> AffineFit:
    """Rotation up to 5 degrees about a random axis, translation up to 2 cm per axis, scales
    0.9 to 1.1, shears up to 0.05."""
    axis = rng.normal(size=3)
    rotation = Rotation.from_rotvec(axis / np.linalg.norm(axis) * np.radians(rng.uniform(2, 5)))
    scale_shear = np.diag(rng.uniform(0.9, 1.1, 3))
    scale_shear[np.triu_indices(3, 1)] = rng.uniform(-0.05, 0.05, 3)
    return AffineFit(rotation.as_matrix() @ scale_shear, rng.uniform(-0.02, 0.02, 3), pivot, 0.0)


def test_rotation_times_upper_triangular_is_recovered_from_the_matrix() -> None:
    rotation = Rotation.from_rotvec([0.02, -0.05, 0.07]).as_matrix()
    scale_shear = np.array([[1.05, 0.03, -0.02], [0.0, 0.92, 0.04], [0.0, 0.0, 1.08]])
    fit = AffineFit(rotation @ scale_shear, np.zeros(3), np.zeros(3), 0.0)
    np.testing.assert_allclose(fit.rotation, rotation, atol=1e-12)
    np.testing.assert_allclose(fit.scale_shear, scale_shear, atol=1e-12)
    np.testing.assert_allclose(fit.rotation_vector_rad, [0.02, -0.05, 0.07], atol=1e-12)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_known_transform_is_recovered_from_the_visible_top(
    model: TwoMuscleMesh, top_points: np.ndarray, seed: int
) -> None:
    surface = model_surface(model)
    truth = _random_transform(np.random.default_rng(seed), surface.vertices_m.mean(axis=0))
    fit = fit_generic_model(truth.apply(top_points), model)
    # Every vertex of the model, the hidden bottom and interface included, lands within 1 mm.
    vertex_error = np.linalg.norm(fit.apply(surface.vertices_m) - truth.apply(surface.vertices_m),
                                  axis=1)
    assert vertex_error.max() < 1e-3
    angle = np.linalg.norm(Rotation.from_matrix(fit.rotation.T @ truth.rotation).as_rotvec())
    assert np.degrees(angle) < 1.0
    np.testing.assert_allclose(fit.scale_shear, truth.scale_shear, atol=5e-3)
    assert fit.rms_m < 1e-4


def test_stray_points_do_not_pull_the_fit(model: TwoMuscleMesh, top_points: np.ndarray) -> None:
    surface = model_surface(model)
    truth = _random_transform(np.random.default_rng(4), surface.vertices_m.mean(axis=0))
    rng = np.random.default_rng(5)
    # 5% of the cloud on the table beside the meat.
    table = np.column_stack([rng.uniform(-0.3, 0.3, 100), rng.uniform(0.15, 0.25, 100),
                             np.full(100, TABLE_Z_M)])
    fit = fit_generic_model(np.vstack([truth.apply(top_points), table]), model)
    vertex_error = np.linalg.norm(fit.apply(surface.vertices_m) - truth.apply(surface.vertices_m),
                                  axis=1)
    assert vertex_error.max() < 5e-3


def test_fitted_model_predicts_the_moved_interface(model: TwoMuscleMesh,
                                                   top_points: np.ndarray) -> None:
    surface = model_surface(model)
    truth = _random_transform(np.random.default_rng(6), surface.vertices_m.mean(axis=0))
    predicted = predict_interface(fit_generic_model(truth.apply(top_points), model), model)
    np.testing.assert_allclose(predicted.top_line_m, truth.apply(model.top_line), atol=1e-3)


def test_interface_of_the_unmoved_model_is_its_own(model: TwoMuscleMesh) -> None:
    identity = AffineFit(np.eye(3), np.zeros(3), np.zeros(3), 0.0)
    predicted = predict_interface(identity, model)
    np.testing.assert_allclose(predicted.top_line_m, model.top_line)
    np.testing.assert_allclose(predicted.bottom_line_m[:, 2], TABLE_Z_M)
    # Below the top line the interface reaches down to the table.
    np.testing.assert_allclose(predicted.depth_below(model.top_line),
                               model.top_line[:, 2] - TABLE_Z_M, atol=1e-12)


def test_too_small_a_cloud_is_refused(model: TwoMuscleMesh) -> None:
    with pytest.raises(PerceptionError, match="12"):
        fit_generic_model(np.zeros((5, 3)), model)


def test_the_closest_point_on_a_triangle_is_its_projection_inside_else_on_an_edge() -> None:
    corners = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],   # z = 0
                        [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]]])  # z = 1
    points = np.array([[0.2, 0.2, 0.3],    # over the first's inside: its projection
                       [0.2, 0.2, 0.7],    # nearer the second
                       [1.0, 1.0, 0.0],    # past the first's long edge: its middle
                       [-1.0, -2.0, 0.1],  # past its corner: the corner
                       [0.2, 0.2, 0.5]])   # as near both: the first candidate
    both = np.tile([0, 1], (len(points), 1))
    closest, triangle = closest_on_triangles(points, corners, both)
    np.testing.assert_allclose(closest, [[0.2, 0.2, 0.0], [0.2, 0.2, 1.0], [0.5, 0.5, 0.0],
                                         [0.0, 0.0, 0.0], [0.2, 0.2, 0.0]], atol=1e-15)
    assert triangle.tolist() == [0, 1, 0, 0, 0]
    assert closest_on_triangles(points[-1:], corners, both[-1:, ::-1])[1].tolist() == [1]
