"""Seeing: pixels to world points, the sensor noise model, the depth mesh and its breaks, fusing
views, and the camera of the default cell."""

from __future__ import annotations

import numpy as np
import pytest

from cell.errors import InputError, PerceptionError
from cell.perception.pointcloud import DepthView, SensorNoise, SurfaceMesh, capture, depth_mesh
from cell.robots.camera import CameraRig
from cell.robots.names import CAMERA
from cell.sim.episode import Episode
from cell.sim.scenario import Scenario

FOCAL_PX = 200.0
HEIGHT_PX, WIDTH_PX = 24, 32


def _look_down(height_m: float) -> tuple[np.ndarray, np.ndarray]:
    """A camera ``height_m`` above the origin looking straight down (its -z is world -z),
    with its x along world y: a rotation that is not the identity."""
    rotation = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    return np.array([0.0, 0.0, height_m]), rotation


def test_pixel_maps_to_camera_frame_by_the_pinhole_formula() -> None:
    depth = np.full((HEIGHT_PX, WIDTH_PX), np.nan)
    u, v, z = 5, 17, 0.8
    depth[v, u] = z
    view = DepthView(depth, FOCAL_PX, np.zeros(3), np.eye(3))
    expected = [(u + 0.5 - WIDTH_PX / 2) * z / FOCAL_PX,
                -(v + 0.5 - HEIGHT_PX / 2) * z / FOCAL_PX, -z]
    np.testing.assert_allclose(view.points_m(), [expected])


def test_flat_floor_seen_from_above_lands_on_the_floor() -> None:
    position, rotation = _look_down(0.6)
    view = DepthView(np.full((HEIGHT_PX, WIDTH_PX), 0.6), FOCAL_PX, position, rotation)
    points = view.points_m()
    assert points.shape == (HEIGHT_PX * WIDTH_PX, 3)
    np.testing.assert_allclose(points[:, 2], 0.0, atol=1e-12)
    # Image right (camera x) is world +y for this camera.
    row = view.grid_points_m()[0]
    assert np.all(np.diff(row[:, 1]) > 0)


def test_binning_takes_block_medians_on_block_centres() -> None:
    depth = np.full((HEIGHT_PX, WIDTH_PX), 0.5)
    depth[0, 0] = 0.9  # one outlier in the first block does not move its median
    view = DepthView(depth, FOCAL_PX, np.zeros(3), np.eye(3))
    grid = view.grid_points_m(bin_px=4)
    assert grid.shape == (HEIGHT_PX // 4, WIDTH_PX // 4, 3)
    np.testing.assert_allclose(grid[..., 2], -0.5)
    # The first block's centre is pixel (1.5, 1.5).
    np.testing.assert_allclose(grid[0, 0, 0], (1.5 + 0.5 - WIDTH_PX / 2) * 0.5 / FOCAL_PX)


def test_noise_grows_with_depth_squared_and_drops_pixels() -> None:
    noise = SensorNoise(sigma_at_1m_m=2e-3, dropout_fraction=0.1)
    near = noise.apply(np.full((400, 400), 0.5), np.random.default_rng(1))
    far = noise.apply(np.full((400, 400), 1.0), np.random.default_rng(2))
    assert np.nanstd(near) == pytest.approx(2e-3 * 0.25, rel=0.02)
    assert np.nanstd(far) == pytest.approx(2e-3, rel=0.02)
    assert np.isnan(near).mean() == pytest.approx(0.1, abs=0.005)


def test_noise_is_repeatable_from_its_seed() -> None:
    depth = np.full((50, 50), 0.7)
    a = SensorNoise().apply(depth, np.random.default_rng(7))
    b = SensorNoise().apply(depth, np.random.default_rng(7))
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize(("field", "value"), [("sigma_at_1m_m", -1e-3),
                                              ("dropout_fraction", 1.0)])
def test_noise_rejects_bad_parameters(field: str, value: float) -> None:
    with pytest.raises(InputError, match=field):
        SensorNoise(**{field: value})


def test_depth_mesh_of_a_plane_is_every_quad_split_facing_the_camera() -> None:
    position, rotation = _look_down(0.6)
    view = DepthView(np.full((HEIGHT_PX, WIDTH_PX), 0.6), FOCAL_PX, position, rotation)
    mesh = depth_mesh(view)
    assert len(mesh.vertices_m) == HEIGHT_PX * WIDTH_PX
    assert len(mesh.triangles) == 2 * (HEIGHT_PX - 1) * (WIDTH_PX - 1)
    normals = mesh.triangle_normals()
    assert np.all(normals @ (position / np.linalg.norm(position)) > 0)  # towards the camera


def test_depth_mesh_breaks_at_a_depth_jump_and_skips_missing_pixels() -> None:
    depth = np.full((HEIGHT_PX, WIDTH_PX), 0.6)
    depth[:, WIDTH_PX // 2:] = 0.7  # a 10 cm step: far steeper than any wall the camera meets
    depth[3, 4] = np.nan
    mesh = depth_mesh(DepthView(depth, FOCAL_PX, np.zeros(3), np.eye(3)))
    z = mesh.vertices_m[mesh.triangles][..., 2]
    assert np.all(np.ptp(z, axis=1) < 1e-12)  # no triangle straddles the step
    assert len(mesh.vertices_m) == HEIGHT_PX * WIDTH_PX - 1
    # The four quads around the missing pixel each keep the one triangle that avoids it.
    assert len(mesh.triangles) == 2 * (HEIGHT_PX - 1) * (WIDTH_PX - 2) - 4


def test_a_gentle_slope_stays_connected() -> None:
    depth = 0.6 + 0.002 * np.arange(WIDTH_PX)[None, :] * np.ones((HEIGHT_PX, 1))
    mesh = depth_mesh(DepthView(depth, FOCAL_PX, np.zeros(3), np.eye(3)))
    assert len(mesh.triangles) == 2 * (HEIGHT_PX - 1) * (WIDTH_PX - 1)


def test_too_few_points_for_a_surface() -> None:
    depth = np.full((HEIGHT_PX, WIDTH_PX), np.nan)
    depth[0, :2] = 0.6
    with pytest.raises(PerceptionError, match="at least 3"):
        depth_mesh(DepthView(depth, FOCAL_PX, np.zeros(3), np.eye(3)))


def test_mesh_rejects_triangles_that_index_nothing() -> None:
    with pytest.raises(InputError, match="triangles"):
        SurfaceMesh(np.zeros((3, 3)), np.array([[0, 1, 3]]))


class _BlindRig:
    """Stands in for a :class:`CameraRig` whose view holds no tissue."""

    focal_px = FOCAL_PX

    def depth(self, data: object) -> np.ndarray:
        return np.full((HEIGHT_PX, WIDTH_PX), 0.6, dtype=np.float32)

    def tissue_mask(self, data: object) -> np.ndarray:
        return np.zeros((HEIGHT_PX, WIDTH_PX), dtype=bool)

    def pose(self, data: object) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros(3), np.eye(3)


def test_a_view_without_meat_is_reported() -> None:
    with pytest.raises(PerceptionError, match="no tissue"):
        capture(_BlindRig(), None)  # type: ignore[arg-type]


# --- the camera of the default cell ---------------------------------------------------------


@pytest.fixture(scope="module")
def episode() -> Episode:
    return Episode(Scenario())


def test_capture_of_the_default_cell_lies_on_the_meat(episode: Episode) -> None:
    with CameraRig(episode.scene.model, CAMERA, 320, 240) as rig:
        view = capture(rig, episode.sim.data)
        noisy = capture(rig, episode.sim.data, SensorNoise(), np.random.default_rng(0))
    mesh = episode.scene.mesh
    vertices = np.concatenate([mesh.round.points, mesh.shank.points])
    points = view.points_m()
    assert len(points) > 10_000
    # Every seen point is on the meat's surface, inside its bounding box (the flex is drawn
    # with a 0.5 mm radius).
    assert np.all(points >= vertices.min(axis=0) - 1e-3)
    assert np.all(points <= vertices.max(axis=0) + 1e-3)
    assert np.isnan(noisy.depth_m).sum() > np.isnan(view.depth_m).sum()  # dropouts


def test_capture_without_a_generator_for_the_noise_is_refused(episode: Episode) -> None:
    with CameraRig(episode.scene.model, CAMERA, 64, 48) as rig, \
            pytest.raises(InputError, match="rng"):
        capture(rig, episode.sim.data, SensorNoise())
