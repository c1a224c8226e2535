"""The two-muscle geometry: node counts, element quality, closed boundaries, interface pairs,
the valley along the top line, MuJoCo flexcomp compilation, and mesh validation errors."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import trimesh

from cell.errors import InputError, MeshError
from cell.tissue.geometry import MuscleShape, TwoMuscleMesh, build_two_muscles
from cell.tissue.tetmesh import (
    TetMesh,
    signed_volumes_m3,
    structured_hex_tets,
    validate_tet_mesh,
)
from tests.tetquality import TetQuality

ORIGIN_M = (0.6, -0.1, 0.8)
DENSITY_KG_M3 = 1050.0


@pytest.fixture(scope="module")
def default() -> TwoMuscleMesh:
    return build_two_muscles(MuscleShape(), origin_m=ORIGIN_M)


@pytest.fixture(scope="module")
def coarse() -> TwoMuscleMesh:
    return build_two_muscles(MuscleShape(cell_size_m=0.05), origin_m=ORIGIN_M)


def _muscles(mesh: TwoMuscleMesh) -> tuple[TetMesh, TetMesh]:
    return mesh.round, mesh.shank


def _nodes(mesh: TwoMuscleMesh) -> int:
    return sum(len(m.points) for m in _muscles(mesh))


def test_node_counts_in_range(default: TwoMuscleMesh, coarse: TwoMuscleMesh) -> None:
    assert 1000 <= _nodes(default) <= 2000
    assert 150 <= _nodes(coarse) <= 300


@pytest.mark.parametrize("name", ["default", "coarse"])
def test_tets_positive_and_well_shaped(name: str, request: pytest.FixtureRequest) -> None:
    mesh: TwoMuscleMesh = request.getfixturevalue(name)
    for muscle in _muscles(mesh):
        assert (signed_volumes_m3(muscle.points, muscle.tets) > 0.0).all()
        quality = TetQuality.of(muscle.points, muscle.tets)
        assert quality.min_dihedral_deg > 18.0
        assert quality.max_dihedral_deg < 135.0
        assert quality.min_radius_ratio > 0.35


def test_fine_mesh_has_no_slivers() -> None:
    mesh = build_two_muscles(MuscleShape(cell_size_m=0.0125))
    for muscle in _muscles(mesh):
        assert TetQuality.of(muscle.points, muscle.tets).min_dihedral_deg > 15.0


def test_boundaries_are_closed_volumes(default: TwoMuscleMesh) -> None:
    n_u, n_round, n_shank, n_w = default.shape.cell_counts()
    for muscle, n_v in zip(_muscles(default), (n_round, n_shank), strict=True):
        shell = trimesh.Trimesh(muscle.points, muscle.boundary, process=False)
        assert shell.is_volume
        tet_sum = signed_volumes_m3(muscle.points, muscle.tets).sum()
        assert shell.volume == pytest.approx(tet_sum, rel=1e-9)
        assert muscle.volume_m3 == pytest.approx(tet_sum, rel=1e-12)
        # A conforming split leaves exactly two triangles per boundary quad of the grid.
        quads = 2 * (n_u * n_v + n_u * n_w + n_v * n_w)
        assert len(muscle.boundary) == 2 * quads


def test_mirrored_split_reflects_across_shared_faces() -> None:
    corners = np.stack(np.meshgrid([0, 1, 2], [0, 1], [0, 1], indexing="ij"), -1).reshape(-1, 3)
    tets = structured_hex_tets((2, 1, 1))
    first, second = tets[:6], tets[6:]
    mirrored = corners[second] * [-1, 1, 1] + [2, 0, 0]

    def as_set(coords: np.ndarray) -> set[tuple]:
        return {tuple(sorted(map(tuple, tet))) for tet in coords.tolist()}

    assert as_set(mirrored) == as_set(corners[first])
    # Each cell is the 6-tet Kuhn split of the cube about one main diagonal.
    assert len(as_set(corners[first])) == 6


def test_pairs_face_each_other_one_to_one(default: TwoMuscleMesh) -> None:
    shape = default.shape
    n_u, _, _, n_w = shape.cell_counts()
    pairs = default.pairs
    assert pairs.shape == ((n_u + 1) * (n_w + 1), 2)
    assert len(np.unique(pairs[:, 0])) == len(pairs)
    assert len(np.unique(pairs[:, 1])) == len(pairs)
    np.testing.assert_allclose(default.pair_rest_lengths_m, shape.gap_m, rtol=1e-9)
    a = default.round.points[pairs[:, 0]]
    b = default.shank.points[pairs[:, 1]]
    np.testing.assert_allclose(a[:, [0, 2]], b[:, [0, 2]], atol=1e-12)
    np.testing.assert_allclose(a[:, 1], default.interface_y(a[:, 0], a[:, 2]) - shape.gap_m / 2)
    np.testing.assert_allclose(b[:, 1], default.interface_y(b[:, 0], b[:, 2]) + shape.gap_m / 2)


def test_interface_passes_through_origin_and_bows(default: TwoMuscleMesh) -> None:
    ox, oy, oz = ORIGIN_M
    half = default.shape.length_m / 2
    assert float(default.interface_y(ox, oz)) == pytest.approx(oy)
    ends = default.interface_y(np.array([ox - half, ox + half]), np.full(2, oz))
    np.testing.assert_allclose(ends, oy - default.shape.interface_bow_m)


def test_top_line_runs_along_a_valley(default: TwoMuscleMesh) -> None:
    line = default.top_line
    ox = ORIGIN_M[0]
    half = default.shape.length_m / 2
    assert (np.diff(line[:, 0]) > 0).all()
    assert line[0, 0] == pytest.approx(ox - half)
    assert line[-1, 0] == pytest.approx(ox + half)
    for muscle in _muscles(default):
        for p in line:
            lateral = np.abs(muscle.points[:, 1] - p[1])
            beside = (np.abs(muscle.points[:, 0] - p[0]) < 1e-9) & (lateral > 0.02)
            beside &= lateral < 0.05
            assert beside.any()
            assert muscle.points[beside, 2].max() > p[2] + 0.005


def _flexcomp_xml(mesh: TwoMuscleMesh) -> str:
    flexes = []
    for name, muscle in zip(("round", "shank"), _muscles(mesh), strict=True):
        points = " ".join(f"{v:.9g}" for v in muscle.points.ravel())
        elements = " ".join(map(str, muscle.tets.ravel()))
        mass = DENSITY_KG_M3 * muscle.volume_m3
        flexes.append(
            f'<flexcomp name="{name}" type="direct" dim="3" point="{points}" '
            f'element="{elements}" mass="{mass:.6g}" radius="0.001">'
            '<contact selfcollide="none"/><elasticity young="3e4" poisson="0.3"/></flexcomp>'
        )
    return (
        '<mujoco><option integrator="discrete" timestep="0.002"/><worldbody>'
        '<geom type="plane" size="1 1 0.1"/>' + "".join(flexes) + "</worldbody></mujoco>"
    )


def test_compiles_as_flexcomp_and_rests_on_a_plane() -> None:
    mesh = build_two_muscles(MuscleShape())
    model = mujoco.MjModel.from_xml_string(_flexcomp_xml(mesh))
    assert model.nflex == 2
    for f, muscle in enumerate(_muscles(mesh)):
        start = model.flex_elemdataadr[f]
        elem = model.flex_elem[start : start + 4 * model.flex_elemnum[f]].reshape(-1, 4)
        # MuJoCo reorders any element it finds inverted; ours must come through unchanged.
        np.testing.assert_array_equal(elem, muscle.tets)
    data = mujoco.MjData(model)
    lowest = np.inf
    for _ in range(100):
        mujoco.mj_step(model, data)
        lowest = min(lowest, data.flexvert_xpos[:, 2].min())
    assert np.isfinite(data.flexvert_xpos).all()
    assert lowest > -0.002
    rest = np.concatenate([m.points for m in _muscles(mesh)])
    assert np.abs(data.flexvert_xpos - rest).max() < 0.01


@pytest.fixture
def tet_pair() -> tuple[np.ndarray, np.ndarray]:
    """Two tets sharing a face: a small valid mesh."""
    points = np.array([[0, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 1], [0, 0, -1]], float)
    return points, np.array([[0, 1, 2, 3], [0, 2, 1, 4]])


def test_validate_accepts_tet_pair(tet_pair: tuple[np.ndarray, np.ndarray]) -> None:
    validate_tet_mesh(*tet_pair, "pair")
    assert TetQuality.of(*tet_pair).min_dihedral_deg > 0


def test_validate_rejects_inverted_tet(tet_pair: tuple[np.ndarray, np.ndarray]) -> None:
    points, tets = tet_pair
    tets = tets.copy()
    tets[1] = tets[1, [0, 2, 1, 3]]
    with pytest.raises(MeshError) as err:
        validate_tet_mesh(points, tets, "pair")
    assert (err.value.file, err.value.field) == ("pair", "tets")
    assert "tet 1" in str(err.value)


def test_validate_rejects_nan_point(tet_pair: tuple[np.ndarray, np.ndarray]) -> None:
    points, tets = tet_pair
    points = points.copy()
    points[3, 2] = np.nan
    with pytest.raises(MeshError) as err:
        validate_tet_mesh(points, tets, "pair")
    assert (err.value.file, err.value.field) == ("pair", "points")
    assert "point 3" in str(err.value)


def test_validate_rejects_open_surface(default: TwoMuscleMesh) -> None:
    muscle = default.round
    with pytest.raises(MeshError) as err:
        validate_tet_mesh(muscle.points, muscle.tets, "round", boundary=muscle.boundary[1:])
    assert err.value.field == "boundary"


@pytest.mark.parametrize(("flipped", "says"), [
    (slice(0, 1), "winding consistent False"),
    (slice(None), "volume -"),
])
def test_validate_rejects_a_boundary_wound_inconsistently_or_inward(
    default: TwoMuscleMesh, flipped: slice, says: str
) -> None:
    muscle = default.round
    boundary = muscle.boundary.copy()
    boundary[flipped] = boundary[flipped, ::-1]
    with pytest.raises(MeshError) as err:
        validate_tet_mesh(muscle.points, muscle.tets, "round", boundary=boundary)
    assert err.value.field == "boundary"
    assert "watertight True" in str(err.value) and says in str(err.value)


@pytest.mark.parametrize("boundary", [np.array([[0, 1, 99]]), np.zeros((2, 3)),
                                      np.zeros((0, 3), int), np.array([0, 1, 2])])
def test_validate_names_a_malformed_boundary(
    tet_pair: tuple[np.ndarray, np.ndarray], boundary: np.ndarray
) -> None:
    with pytest.raises(MeshError) as err:
        validate_tet_mesh(*tet_pair, "pair", boundary=boundary)
    assert (err.value.file, err.value.field) == ("pair", "boundary")


def test_validate_rejects_tets_touching_along_an_edge_only() -> None:
    points = np.array([[0, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 1], [-1, 0, 0], [0, -1, 0]], float)
    # Opposite quadrants, sharing only the edge (0, 3): every face is on the boundary, which is
    # closed but pinched along that edge, so it bounds no proper volume.
    tets = np.array([[0, 1, 2, 3], [0, 5, 4, 3]])
    assert (signed_volumes_m3(points, tets) > 0).all()
    with pytest.raises(MeshError) as err:
        validate_tet_mesh(points, tets, "pair")
    assert err.value.field == "boundary"


@pytest.mark.parametrize(
    ("tets", "field"),
    [(np.array([[0, 1, 2, 7]]), "tets"), (np.array([[0, 1, 2, 3]]), "points")],
)
def test_validate_rejects_bad_indices_and_unused_points(
    tet_pair: tuple[np.ndarray, np.ndarray], tets: np.ndarray, field: str
) -> None:
    with pytest.raises(MeshError) as err:
        validate_tet_mesh(tet_pair[0], tets, "pair")
    assert err.value.field == field


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"length_m": -0.1}, "length_m"),
        ({"gap_m": 0.0}, "gap_m"),
        ({"valley_depth_m": 0.09}, "valley_depth_m"),
        ({"round_width_m": 0.04}, "round_width_m"),
        ({"cell_size_m": float("nan")}, "cell_size_m"),
        ({"interface_lean": 2.0}, "interface_lean"),
        ({"valley_width_m": 0.01}, "valley_width_m"),
        ({"end_taper": 0.8}, "end_taper"),
        ({"shank_height_m": True}, "shank_height_m"),
    ],
)
def test_shape_rejects_bad_fields(change: dict[str, float], field: str) -> None:
    with pytest.raises(InputError) as err:
        MuscleShape(**change)
    assert err.value.field == field
