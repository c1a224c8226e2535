"""The Cohen-Steiner and Morvan curvature tensor against analytic surfaces, meshed with uneven
triangles (vertices jittered along the surface by up to 30% of an edge), and its sign
convention.

Tolerances, for a ball of twice the mean edge length: mean curvature within 5%, principal
curvatures within 15%, Gaussian curvature within 25% of the analytic values (a discrete
estimate on an uneven mesh; the ball's own tilt over a curved surface biases it low by about
(r / R)^2 / 2).
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from cell.errors import InputError, PerceptionError
from cell.perception.curvature import surface_curvature
from cell.perception.pointcloud import SurfaceMesh

JITTER = 0.3  # of the grid step or mean edge length


def _uneven(mesh: SurfaceMesh) -> float:
    """Ratio of the smallest to the largest triangle area."""
    areas = np.linalg.norm(mesh.triangle_normals(), axis=1)
    return float(areas.min() / areas.max())


def _grid(rows: int, cols: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray,
                                                                      np.ndarray]:
    """Parameters (s, t) in [0, 1]^2 of a jittered grid (border kept straight) and its
    triangles, counter-clockwise in the (s, t) plane."""
    s, t = np.meshgrid(np.linspace(0, 1, rows), np.linspace(0, 1, cols), indexing="ij")
    js = rng.uniform(-JITTER, JITTER, s.shape) / (rows - 1)
    jt = rng.uniform(-JITTER, JITTER, t.shape) / (cols - 1)
    js[[0, -1], :] = 0.0
    jt[:, [0, -1]] = 0.0
    ids = np.arange(rows * cols).reshape(rows, cols)
    a, b, c, d = ids[:-1, :-1], ids[1:, :-1], ids[:-1, 1:], ids[1:, 1:]
    triangles = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                                np.stack([b, d, c], -1).reshape(-1, 3)])
    return (s + js).ravel(), (t + jt).ravel(), triangles


def _mean_edge(mesh: SurfaceMesh) -> float:
    v = mesh.vertices_m[mesh.triangles]
    return float(np.linalg.norm(v - np.roll(v, 1, axis=1), axis=2).mean())


@pytest.fixture(scope="module")
def sphere() -> SurfaceMesh:
    """An icosphere of radius 0.05 m (2562 vertices) with vertices slid along the sphere."""
    rng = np.random.default_rng(0)
    ico = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    v = ico.vertices.copy()
    step = ico.edges_unique_length.mean()
    shift = rng.uniform(-JITTER, JITTER, v.shape) * step
    shift -= np.sum(shift * v, axis=1, keepdims=True) * v  # tangential only
    v += shift
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return SurfaceMesh(0.05 * v, ico.faces.astype(np.int64))


R_CYL_M = 0.04


@pytest.fixture(scope="module")
def cylinder() -> SurfaceMesh:
    """A patch of a cylinder of radius 0.04 m about the x axis (2.5 rad by 0.2 m), wound
    outward."""
    s, t, triangles = _grid(60, 50, np.random.default_rng(1))
    angle, x = 2.5 * s - 1.25, 0.2 * t - 0.1
    points = np.stack([x, R_CYL_M * np.sin(angle), R_CYL_M * np.cos(angle)], axis=1)
    return SurfaceMesh(points, triangles[:, [0, 2, 1]])


A_SADDLE_M = 0.05


@pytest.fixture(scope="module")
def saddle() -> SurfaceMesh:
    """z = (x^2 - y^2) / (2 a) over 0.1 m x 0.1 m, wound so its normals point up."""
    s, t, triangles = _grid(60, 60, np.random.default_rng(2))
    x, y = 0.1 * s - 0.05, 0.1 * t - 0.05
    return SurfaceMesh(np.stack([x, y, (x**2 - y**2) / (2 * A_SADDLE_M)], axis=1), triangles)


def test_meshes_are_uneven(sphere: SurfaceMesh, cylinder: SurfaceMesh,
                           saddle: SurfaceMesh) -> None:
    for mesh in (sphere, cylinder, saddle):
        assert _uneven(mesh) < 0.2


def test_sphere_has_both_principal_curvatures_one_over_r(sphere: SurfaceMesh) -> None:
    curv = surface_curvature(sphere, 2 * _mean_edge(sphere))
    inv_r = 1 / 0.05
    np.testing.assert_allclose(curv.mean_1_m, inv_r, rtol=0.05)
    np.testing.assert_allclose(curv.min_1_m, inv_r, rtol=0.15)
    np.testing.assert_allclose(curv.max_1_m, inv_r, rtol=0.15)
    np.testing.assert_allclose(curv.gaussian_1_m2, inv_r**2, rtol=0.25)
    radial = sphere.vertices_m / 0.05
    assert np.degrees(np.arccos(np.einsum("ij,ij->i", curv.normals, radial).min())) < 5.0


def test_cylinder_bends_one_way_only(cylinder: SurfaceMesh) -> None:
    radius = 2 * _mean_edge(cylinder)
    curv = surface_curvature(cylinder, radius)
    x, y, z = cylinder.vertices_m.T
    # Away from the border, where the ball is whole (an edge more for the jitter).
    margin = radius + _mean_edge(cylinder)
    inner = (np.abs(x) < 0.1 - margin) & (np.abs(np.arctan2(y, z)) < 1.25 - margin / R_CYL_M)
    assert inner.sum() > 1000
    np.testing.assert_allclose(curv.mean_1_m[inner], 1 / (2 * R_CYL_M), rtol=0.05)
    np.testing.assert_allclose(curv.max_1_m[inner], 1 / R_CYL_M, rtol=0.15)
    assert np.abs(curv.min_1_m[inner]).max() < 0.15 / R_CYL_M
    assert np.abs(curv.gaussian_1_m2[inner]).max() < 0.15 / R_CYL_M**2
    # No bending along the axis: the least curvature's direction is the axis.
    assert np.abs(curv.min_directions[inner, 0]).min() > 0.95
    assert np.abs(curv.max_directions[inner, 0]).max() < 0.3


def test_saddle_has_negative_gaussian_curvature_at_its_centre(saddle: SurfaceMesh) -> None:
    curv = surface_curvature(saddle, 2 * _mean_edge(saddle))
    near = np.hypot(*saddle.vertices_m[:, :2].T) < 0.01
    assert near.sum() > 20
    assert np.all(curv.gaussian_1_m2[near] < 0)
    np.testing.assert_allclose(curv.gaussian_1_m2[near], -1 / A_SADDLE_M**2, rtol=0.25)
    assert np.abs(curv.mean_1_m[near]).max() < 0.05 / A_SADDLE_M
    np.testing.assert_allclose(curv.max_1_m[near], 1 / A_SADDLE_M, rtol=0.15)
    np.testing.assert_allclose(curv.min_1_m[near], -1 / A_SADDLE_M, rtol=0.15)
    # Seen along its upward normals it is a bowl (concave) along x and a dome along y.
    assert np.abs(curv.min_directions[near, 0]).min() > 0.9
    assert np.abs(curv.max_directions[near, 1]).min() > 0.9


def test_turning_the_surface_over_turns_a_ridge_into_a_valley(cylinder: SurfaceMesh) -> None:
    flipped = SurfaceMesh(cylinder.vertices_m, cylinder.triangles[:, [0, 2, 1]])
    up = surface_curvature(cylinder, 0.01)
    down = surface_curvature(flipped, 0.01)
    np.testing.assert_allclose(down.mean_1_m, -up.mean_1_m, atol=1e-9)
    np.testing.assert_allclose(down.normals, -up.normals, atol=1e-9)


def test_a_flat_patch_has_no_curvature() -> None:
    s, t, triangles = _grid(20, 20, np.random.default_rng(3))
    mesh = SurfaceMesh(np.stack([s, t, np.zeros_like(s)], axis=1), triangles)
    curv = surface_curvature(mesh, 0.15)
    np.testing.assert_allclose(curv.mean_1_m, 0.0, atol=1e-9)
    np.testing.assert_allclose(curv.normals, np.tile([0, 0, 1.0], (len(s), 1)), atol=1e-9)


def test_bad_radius_and_empty_mesh_are_refused(sphere: SurfaceMesh) -> None:
    with pytest.raises(InputError, match="radius_m"):
        surface_curvature(sphere, 0.0)
    with pytest.raises(PerceptionError, match="no triangle"):
        surface_curvature(SurfaceMesh(np.zeros((1, 3)), np.zeros((0, 3), dtype=np.int64)), 0.01)
