"""CAD parts: coacd's convex pieces of the example meshes, their cache, the knife and the
clamp in a running cell."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from cell.errors import NotWatertightError
from cell.robots.cad import CACHE_ENV, decompose
from cell.robots.tools import FixtureParams, KnifeParams, build_knife
from cell.sim.episode import Episode
from cell.sim.scenario import Scenario
from cell.tissue.geometry import MuscleShape
from tests.paths import PROJECT_ROOT

TOOLS = PROJECT_ROOT / "assets" / "meshes" / "tools"
HANDLE = TOOLS / "boning_knife_handle.stl"
CLAMP = TOOLS / "fixture_clamp.stl"


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """A cache folder of this module's own (never the user's)."""
    folder = tmp_path_factory.mktemp("cache")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv(CACHE_ENV, str(folder))
        yield folder


def test_the_handle_is_cut_into_convex_pieces_close_to_its_volume(cache: Path) -> None:
    part = decompose(HANDLE, "knife.handle_mesh")
    assert not part.cache_hit
    assert len(part.pieces) >= 2  # the bow makes it concave
    assert all(piece.is_convex for piece in part.pieces)
    assert 0.0 < part.volume_error < 0.1
    again = decompose(HANDLE, "knife.handle_mesh")
    assert again.cache_hit
    for first, second in zip(part.pieces, again.pieces, strict=True):
        np.testing.assert_array_equal(first.vertices, second.vertices)
    # One file a mesh, no temporary left behind.
    assert [p.suffix for p in (cache / "coacd").iterdir()] == [".npz"]


def test_another_concavity_is_another_cache_entry(cache: Path) -> None:
    decompose(HANDLE, "knife.handle_mesh")
    coarse = decompose(HANDLE, "knife.handle_mesh", concavity=0.2)
    assert not coarse.cache_hit
    assert len(coarse.pieces) == 1


def test_an_open_cad_mesh_is_refused_and_nothing_is_cached(cache: Path, tmp_path: Path) -> None:
    box = trimesh.creation.box((0.05, 0.05, 0.05))
    box.update_faces(np.arange(1, len(box.faces)))
    box.export(tmp_path / "open.stl")
    before = sorted((cache / "coacd").glob("*")) if (cache / "coacd").exists() else []
    with pytest.raises(NotWatertightError, match=r"open.stl, fixture.clamp_mesh: not a closed"):
        decompose(tmp_path / "open.stl", "fixture.clamp_mesh")
    after = sorted((cache / "coacd").glob("*")) if (cache / "coacd").exists() else []
    assert before == after


def test_the_cad_handle_keeps_the_knife_s_mass_and_collides_as_its_pieces(cache: Path) -> None:
    plain = build_knife(KnifeParams()).compile()
    cad = build_knife(KnifeParams(handle_mesh=str(HANDLE))).compile()
    assert cad.body("knife").mass[0] == pytest.approx(plain.body("knife").mass[0])
    visual, pieces = cad.geom("handle"), [cad.geom(f"handle_{i}") for i in range(2)]
    assert visual.contype[0] == visual.conaffinity[0] == 0
    assert all(piece.type[0] == mujoco.mjtGeom.mjGEOM_MESH and piece.contype[0]
               for piece in pieces)


def test_an_episode_runs_with_the_cad_knife_and_clamp(cache: Path) -> None:
    base = Scenario(tissue=MuscleShape(cell_size_m=0.05), end_s=0.4,
                    knife=KnifeParams(handle_mesh=str(HANDLE)),
                    fixture=FixtureParams(clamp_mesh=str(CLAMP)))
    scenario = replace(base, perception=replace(base.perception, enabled=False))
    episode = Episode(scenario)
    model = episode.scene.model
    clamp = [model.geom(f"clamp_{i}") for i in range(6)]
    assert all(geom.bodyid[0] == model.body("fixture").id for geom in clamp)
    # It stands clear of the round's outer wall at rest: no contact with the tissue.
    data = episode.sim.data
    mujoco.mj_forward(model, data)
    ids = {geom.id for geom in clamp}
    touching = [c for c in data.contact[:data.ncon] if ids & set(c.geom.tolist())]
    assert touching == []
    summary = episode.run()
    assert summary["result"]["cad_parts"]["fixture.clamp_mesh"]["pieces"] == 6
    assert summary["result"]["cad_parts"]["knife.handle_mesh"]["source"] == HANDLE.name
    assert summary["result"]["sim_time_s"] == pytest.approx(0.4)
