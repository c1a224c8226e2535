"""Scanned muscles: the example scan's repair, tets and interface; the bad meshes' named
errors (nothing written); the example scan's whole episode (slow)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from cell.cli import main
from cell.errors import (
    MeshError,
    NoInterfaceError,
    NotWatertightError,
    ScenarioError,
    SelfIntersectionError,
    TetrahedralisationError,
)
from cell.sim.episode import Episode
from cell.sim.scenario import load_scenario
from cell.tissue.geometry import MuscleShape, build_two_muscles
from cell.tissue.mesher import tetrahedralise
from cell.tissue.scan import build_tissue
from cell.tissue.surface import load_surfaces
from tests.paths import PROJECT_ROOT

SCAN = PROJECT_ROOT / "assets" / "meshes" / "scan"
EXAMPLE = PROJECT_ROOT / "scenarios" / "example_scan.toml"
FIELD = "tissue.surface_mesh"


@pytest.fixture(scope="module")
def scanned() -> object:
    shape = MuscleShape(surface_mesh=(str(SCAN / "round.ply"), str(SCAN / "shank.ply")),
                        cell_size_m=0.035)
    return build_tissue(shape, origin_m=(0.0, 0.0, 0.6))


def write(tmp_path: Path, name: str, *bodies: trimesh.Trimesh) -> Path:
    path = tmp_path / name
    trimesh.util.concatenate(list(bodies)).export(path)
    return path


def muscle_boxes(gap_m: float) -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """A round and a shank as two boxes on the table, ``gap_m`` apart across y = 0."""
    size = (0.3, 0.1, 0.08)
    round_box = trimesh.creation.box(size).apply_translation((0.0, -0.05 - gap_m / 2, 0.04))
    shank_box = trimesh.creation.box(size).apply_translation((0.0, 0.05 + gap_m / 2, 0.04))
    return round_box, shank_box


def test_the_example_scan_has_holes_the_repair_closes() -> None:
    raw = trimesh.load(SCAN / "round.ply", process=False)
    assert not raw.is_watertight
    [repaired] = load_surfaces(SCAN / "round.ply", FIELD)
    assert repaired.is_volume
    assert (SCAN / "round.ply").stat().st_size + (SCAN / "shank.ply").stat().st_size < 100_000


def test_the_scan_is_bound_like_the_procedural_shape_it_was_made_from(scanned) -> None:
    truth = build_two_muscles(MuscleShape(cell_size_m=0.035), origin_m=(0.0, 0.0, 0.6))
    assert scanned.interface_area_m2 == pytest.approx(truth.interface_area_m2, rel=0.05)
    # Each binding spans the gap of the scan (3 mm and noise) or a mesh spacing at most.
    assert scanned.pair_rest_lengths_m.min() > 0.001
    assert scanned.pair_rest_lengths_m.max() < 2 * 0.035
    # The knife enters along the valley: the top line follows the truth's within millimetres.
    true_y = truth.interface_y(scanned.top_line[:, 0], scanned.top_line[:, 2])
    assert np.abs(scanned.top_line[:, 1] - true_y).max() < 0.004
    assert np.ptp(scanned.top_line[:, 0]) == pytest.approx(0.45, abs=0.01)
    fitted = scanned.interface_y(truth.pair_midpoints_m[:, 0], truth.pair_midpoints_m[:, 2])
    assert np.abs(fitted - truth.pair_midpoints_m[:, 1]).max() < 0.003
    # Both bases lie on the table, so the round is pinned and the shank stands on feet.
    assert np.isclose(scanned.round.points[:, 2].min(), 0.6)
    assert np.isclose(scanned.shank.points[:, 2].min(), 0.6)


def test_one_file_with_both_bodies_is_split_round_first(tmp_path: Path) -> None:
    path = write(tmp_path, "both.ply", *reversed(muscle_boxes(0.002)))
    mesh = build_tissue(MuscleShape(surface_mesh=(str(path),), cell_size_m=0.04))
    assert mesh.round.points[:, 1].mean() < 0 < mesh.shank.points[:, 1].mean()
    assert mesh.interface_area_m2 == pytest.approx(0.3 * 0.08, rel=0.05)


def test_a_hole_too_large_to_fill_is_not_watertight(tmp_path: Path) -> None:
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=0.05)
    sphere.apply_translation((0.0, 0.0, 0.06))
    top = np.argsort(sphere.triangles_center[:, 2])[-6:]  # a cap of six faces
    sphere.update_faces(np.setdiff1d(np.arange(len(sphere.faces)), top))
    path = write(tmp_path, "holed.ply", sphere)
    with pytest.raises(NotWatertightError, match=r"holed.ply, tissue.surface_mesh: not a closed"):
        load_surfaces(path, FIELD)


def test_a_surface_that_crosses_itself_is_refused(tmp_path: Path) -> None:
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=0.05)
    sphere.apply_translation((0.0, -0.06, 0.1))
    vertices = np.array(sphere.vertices)
    vertices[np.argmax(vertices[:, 2]), 2] -= 0.13  # the north pole out through the south
    sphere.vertices = vertices
    path = write(tmp_path, "crossed.ply", sphere, muscle_boxes(0.002)[1])
    with pytest.raises(SelfIntersectionError, match=r"crossed.ply, tissue.surface_mesh"):
        build_tissue(MuscleShape(surface_mesh=(str(path),)))


def test_muscles_that_do_not_meet_have_no_interface(tmp_path: Path) -> None:
    round_box, shank_box = muscle_boxes(0.02)
    paths = (write(tmp_path, "round.ply", round_box), write(tmp_path, "shank.ply", shank_box))
    with pytest.raises(NoInterfaceError, match=r"round.ply and .*shank.ply.*closest 0.02 m"):
        build_tissue(MuscleShape(surface_mesh=tuple(map(str, paths)), cell_size_m=0.04))


def test_a_closed_surface_with_no_volume_fails_tetrahedralisation() -> None:
    # A square covered on both sides: closed and consistently wound, but flat.
    flat = trimesh.Trimesh([[0, 0, 0], [0.1, 0, 0], [0.1, 0.1, 0], [0, 0.1, 0]],
                           [[0, 1, 2], [0, 2, 3], [0, 2, 1], [0, 3, 2]], process=False)
    with pytest.raises(TetrahedralisationError, match=r"flat.ply, tissue.surface_mesh: TetGen"):
        tetrahedralise(flat, "flat.ply", FIELD, cell_size_m=0.05)


def test_three_bodies_are_not_two_muscles(tmp_path: Path) -> None:
    extra = trimesh.creation.box((0.05, 0.05, 0.05)).apply_translation((0.0, 0.3, 0.025))
    path = write(tmp_path, "three.ply", *muscle_boxes(0.002), extra)
    with pytest.raises(MeshError, match=r"three.ply.*exactly two closed bodies"):
        build_tissue(MuscleShape(surface_mesh=(str(path),)))


def test_a_scenario_names_one_scan_as_a_string_relative_to_itself(tmp_path: Path) -> None:
    write(tmp_path, "both.ply", *muscle_boxes(0.002))
    (tmp_path / "s.toml").write_text('[tissue]\nsurface_mesh = "both.ply"\n')
    assert load_scenario(tmp_path / "s.toml").tissue.surface_mesh == (str(tmp_path / "both.ply"),)
    (tmp_path / "s.toml").write_text('[tissue]\nsurface_mesh = ["gone.ply"]\n')
    with pytest.raises(ScenarioError, match=r"tissue.surface_mesh: file not found: gone.ply"):
        load_scenario(tmp_path / "s.toml")


def test_a_bad_scan_exits_2_and_writes_nothing(tmp_path: Path) -> None:
    round_box, shank_box = muscle_boxes(0.02)
    paths = (write(tmp_path, "round.ply", round_box), write(tmp_path, "shank.ply", shank_box))
    (tmp_path / "s.toml").write_text(f'[tissue]\nsurface_mesh = ["{paths[0].name}", '
                                     f'"{paths[1].name}"]\n')
    summary, rrd = tmp_path / "summary.json", tmp_path / "x.rrd"
    code = main(["run", str(tmp_path / "s.toml"), "--out", str(summary), "--rerun",
                 str(rrd), "--quiet"])
    assert code == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["round.ply", "s.toml", "shank.ply"]


@pytest.mark.slow
def test_the_example_scan_episode_separates_the_muscles() -> None:
    result = Episode(load_scenario(EXAMPLE)).run()["result"]
    assert result["released_fraction"] >= 0.95
    assert result["muscles_apart"]
    mesh = result["tissue_mesh"]
    assert mesh["source"] == ["round.ply", "shank.ply"]
    assert mesh["nodes"] == result["tissue_nodes"] > 300
    assert 0.0 < mesh["min_dihedral_deg"] < 70.6
    assert mesh["interface_area_m2"] == pytest.approx(0.031, rel=0.05)
