"""The aponeurosis: the segment-box test, and on a coarse scene the bindings' rest lengths, their
release by the knife and by tearing, the forces they carry and the release record."""

from __future__ import annotations

from collections import Counter
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from cell.robots.tools import KnifeParams
from cell.sim.assembly import Scene, build_scene
from cell.sim.scenario import AponeurosisParams, Scenario
from cell.tissue.aponeurosis import Aponeurosis, BindingLaw, ReleaseRule, segments_cross_box
from cell.tissue.geometry import MuscleShape

UNIT_BOX = np.array([1.0, 1.0, 1.0])
BLADE = KnifeParams().blade_half_size_m
SCENARIO = Scenario(tissue=MuscleShape(cell_size_m=0.05))


def _crosses(start: list[float], end: list[float], half: np.ndarray = UNIT_BOX) -> bool:
    result = segments_cross_box(np.array([start], float), np.array([end], float), half)
    assert result.shape == (1,)
    return bool(result[0])


# --- segments_cross_box ------------------------------------------------------------------------


def test_segment_through_the_box_crosses() -> None:
    assert _crosses([-2.0, 0.0, 0.0], [2.0, 0.0, 0.0])
    assert _crosses([-2.0, -2.0, -2.0], [2.0, 2.0, 2.0])  # through the centre, diagonally
    assert _crosses([2.0, 0.3, -0.2], [-2.0, 0.1, 0.4])  # direction does not matter


def test_segment_beside_the_box_misses() -> None:
    assert not _crosses([-2.0, 1.5, 0.0], [2.0, 1.5, 0.0])
    assert not _crosses([-2.0, 0.0, -3.0], [2.0, 0.5, -1.2])
    # Its line clips a corner region but the segment passes outside it.
    assert not _crosses([-2.0, 0.0, 0.0], [0.0, 2.5, 0.0])


def test_segment_ending_just_short_misses() -> None:
    assert not _crosses([-2.0, 0.0, 0.0], [-1.001, 0.0, 0.0])
    assert not _crosses([1.001, 0.2, 0.2], [3.0, 0.2, 0.2])  # starting just past it
    assert _crosses([-2.0, 0.0, 0.0], [-0.999, 0.0, 0.0])
    assert _crosses([-2.0, 0.0, 0.0], [-1.0, 0.0, 0.0])  # touching the face counts


def test_segment_parallel_to_a_face() -> None:
    assert _crosses([-2.0, 0.5, 0.5], [2.0, 0.5, 0.5])  # inside the slab
    assert _crosses([-2.0, 1.0, 0.0], [2.0, 1.0, 0.0])  # in the face's plane
    assert not _crosses([-2.0, 1.001, 0.0], [2.0, 1.001, 0.0])  # just outside
    assert not _crosses([-2.0, 0.0, -1.5], [2.0, 0.0, -1.5])


def test_segment_fully_inside_crosses() -> None:
    assert _crosses([-0.1, 0.0, 0.0], [0.1, 0.2, -0.3])
    assert _crosses([0.5, 0.5, 0.5], [0.5, 0.5, 0.5])  # a point inside
    assert not _crosses([1.5, 0.5, 0.5], [1.5, 0.5, 0.5])  # a point outside


def test_segment_across_a_thin_blade_box() -> None:
    # A binding 3 mm long across a 1 mm thick blade, and one beside the blade's edge.
    blade = KnifeParams().blade_half_size_m
    assert _crosses([0.0, -0.0015, 0.0], [0.0, 0.0015, 0.0], blade)
    assert not _crosses([blade[0] + 1e-4, -0.0015, 0.0], [blade[0] + 1e-4, 0.0015, 0.0], blade)
    assert not _crosses([0.0, 0.001, 0.0], [0.0, 0.004, 0.0], blade)  # wholly on one side


def test_segments_cross_box_agrees_with_dense_sampling() -> None:
    rng = np.random.default_rng(3)
    half = np.array([0.5, 0.2, 1.0])
    start = rng.uniform(-2.0, 2.0, (1000, 3))
    end = rng.uniform(-2.0, 2.0, (1000, 3))
    result = segments_cross_box(start, end, half)
    t = np.linspace(0.0, 1.0, 1001)[None, :, None]
    samples = start[:, None, :] + t * (end - start)[:, None, :]
    outside = (np.abs(samples) - half).max(axis=2).min(axis=1)  # <= 0: a sample is inside
    step = np.linalg.norm(end - start, axis=1) / 1000
    assert result[outside <= 0].all()
    assert not result[outside > step].any()
    assert 0.1 < result.mean() < 0.9  # both outcomes are exercised


# --- bindings on a coarse scene ----------------------------------------------------------------


@pytest.fixture(scope="module", params=[BindingLaw.SPRING, BindingLaw.CONSTRAINT])
def scene(request: pytest.FixtureRequest) -> Scene:
    """The coarse scene, once with binding springs and once with connect constraints."""
    # The force rule needs the spring law: both laws release by position and tearing here.
    law = AponeurosisParams(law=request.param.value, release_rules=("knife", "tearing"))
    return build_scene(replace(SCENARIO, aponeurosis=law))


def _assert_active(apo: Aponeurosis, data: mujoco.MjData) -> None:
    """The constraint law's equalities are switched on exactly for the bound bindings."""
    if apo.law is BindingLaw.CONSTRAINT:
        np.testing.assert_array_equal(data.eq_active[apo.equality_ids].astype(bool), apo.bound)
    else:
        assert len(apo.equality_ids) == 0


@pytest.fixture
def data(scene: Scene) -> mujoco.MjData:
    """Fresh state at the model's rest pose, every binding bound and its record cleared."""
    data = mujoco.MjData(scene.model)
    scene.aponeurosis.reset(data)
    mujoco.mj_forward(scene.model, data)
    return data


def _blade_across_interface(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Blade centre, rotation (flattened, columns = blade axes in world) and the x of the
    interface column it is put on: the column of facing pairs nearest the middle of the length.

    The blade's thin y axis is the interface normal (the interface leans by ``interface_lean``),
    its centre the middle of that column, so every binding of the column crosses it."""
    mesh = scene.mesh
    mid = (mesh.round.points[mesh.pairs[:, 0]] + mesh.shank.points[mesh.pairs[:, 1]]) / 2
    column_x = mid[np.argmin(np.abs(mid[:, 0] - mesh.origin_m[0])), 0]
    column = mid[np.isclose(mid[:, 0], column_x)]
    normal = np.array([0.0, 1.0, -SCENARIO.tissue.interface_lean])
    normal /= np.linalg.norm(normal)
    x_axis = np.array([1.0, 0.0, 0.0])
    rot = np.column_stack([x_axis, normal, np.cross(x_axis, normal)])
    return column.mean(axis=0), rot.ravel(), column_x


def test_all_bindings_bound_at_start(scene: Scene, data: mujoco.MjData) -> None:
    apo = scene.aponeurosis
    assert len(apo) == len(scene.mesh.pairs) > 0
    assert apo.bound.all()
    assert scene.model.eq_active0[apo.equality_ids].all()
    _assert_active(apo, data)
    assert apo.released_counts() == {"knife": 0, "tearing": 0, "force": 0}


def test_rest_lengths_are_the_gap(scene: Scene, data: mujoco.MjData) -> None:
    apo = scene.aponeurosis
    gap = SCENARIO.tissue.gap_m
    np.testing.assert_allclose(apo.rest_length_m, gap, atol=1e-6)
    np.testing.assert_allclose(apo.lengths(data), gap, atol=1e-6)
    np.testing.assert_allclose(apo.rest_length_m, scene.mesh.pair_rest_lengths_m, atol=1e-6)


def test_bindings_join_the_facing_vertices(scene: Scene, data: mujoco.MjData) -> None:
    apo = scene.aponeurosis
    a, b = apo.endpoints(data)
    np.testing.assert_allclose(a, scene.mesh.round.points[apo.pairs[:, 0]], atol=1e-6)
    np.testing.assert_allclose(b, scene.mesh.shank.points[apo.pairs[:, 1]], atol=1e-6)


def test_knife_releases_only_bindings_under_the_blade(scene: Scene, data: mujoco.MjData) -> None:
    apo = scene.aponeurosis
    margin = SCENARIO.aponeurosis.knife_margin_m
    half = KnifeParams().blade_half_size_m
    pos, mat, column_x = _blade_across_interface(scene)
    a, b = apo.endpoints(data)
    x = (a[:, 0] + b[:, 0]) / 2
    expected = np.flatnonzero(np.abs(x - pos[0]) <= half[0] + margin)
    assert len(expected) > 0
    assert len(expected) < len(apo)  # other columns lie beyond the blade's width
    np.testing.assert_allclose(x[expected], column_x)

    released = apo.release_by_knife(data, 1.25, apo.under_blade(data, pos, mat, half, margin))

    np.testing.assert_array_equal(np.sort(released), expected)
    _assert_active(apo, data)
    for record in apo.records():
        if record.index in expected:
            assert record.released_by is ReleaseRule.KNIFE
            assert record.released_at_s == 1.25
        else:
            assert record.released_by is None
            assert record.released_at_s is None
    assert apo.released_counts() == {"knife": len(expected), "tearing": 0, "force": 0}


def test_knife_releases_a_binding_once(scene: Scene, data: mujoco.MjData) -> None:
    apo = scene.aponeurosis
    half = KnifeParams().blade_half_size_m
    pos, mat, _ = _blade_across_interface(scene)
    first = apo.release_by_knife(data, 1.0, apo.under_blade(data, pos, mat, half, 0.003))
    again = apo.release_by_knife(data, 2.0, apo.under_blade(data, pos, mat, half, 0.003))
    assert len(first) > 0
    assert len(again) == 0
    assert set(apo.released_at_s[first]) == {1.0}  # the first release time is kept


@pytest.mark.parametrize(("margin_m", "releases"), [(0.003, True), (0.0, False)])
def test_knife_margin_reaches_beyond_the_blade_edge(
    scene: Scene, data: mujoco.MjData, margin_m: float, releases: bool
) -> None:
    apo = scene.aponeurosis
    half = KnifeParams().blade_half_size_m
    pos, mat, column_x = _blade_across_interface(scene)
    # The column lies 1.5 mm beyond the blade's edge: within a 3 mm margin, outside none.
    pos = pos + np.array([half[0] + 0.0015, 0.0, 0.0])
    released = apo.release_by_knife(data, 1.0, apo.under_blade(data, pos, mat, half, margin_m))
    a, b = apo.endpoints(data)
    column = np.flatnonzero(np.isclose((a[:, 0] + b[:, 0]) / 2, column_x))
    if releases:
        np.testing.assert_array_equal(np.sort(released), column)
    else:
        assert len(released) == 0


def test_knife_beside_the_meat_releases_nothing(scene: Scene, data: mujoco.MjData) -> None:
    apo = scene.aponeurosis
    pos, mat, _ = _blade_across_interface(scene)
    pos = pos + np.array([SCENARIO.tissue.length_m, 0.0, 0.0])  # past the end of the meat
    released = apo.release_by_knife(data, 1.0, apo.under_blade(data, pos, mat, BLADE, 0.003))
    assert len(released) == 0
    assert apo.bound.all()


def _move_vertex_body(
    model: mujoco.MjModel, data: mujoco.MjData, body: int, offset_m: np.ndarray
) -> None:
    """Shift a flex vertex body (three slide joints) by ``offset_m`` in world axes."""
    for j in range(model.body_jntadr[body], model.body_jntadr[body] + model.body_jntnum[body]):
        assert model.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE
        data.qpos[model.jnt_qposadr[j]] += float(model.jnt_axis[j] @ offset_m)
    mujoco.mj_forward(model, data)


def test_tearing_releases_exactly_the_stretched_binding(scene: Scene, data: mujoco.MjData) -> None:
    apo = scene.aponeurosis
    index = len(apo) // 2
    body = apo.shank_bodies[index]
    expected = np.flatnonzero(apo.shank_bodies == body)
    start = data.xpos[body].copy()
    _move_vertex_body(scene.model, data, body, np.array([0.0, 0.02, 0.0]))
    np.testing.assert_allclose(data.xpos[body] - start, [0.0, 0.02, 0.0], atol=1e-9)

    released = apo.release_by_tearing(data, 0.5, SCENARIO.aponeurosis.tearing_stretch_m)

    np.testing.assert_array_equal(np.sort(released), expected)
    assert apo.released_by[index] is ReleaseRule.TEARING
    assert apo.released_at_s[index] == 0.5
    _assert_active(apo, data)
    assert apo.released_counts() == {"knife": 0, "tearing": len(expected), "force": 0}


def test_tearing_spares_a_binding_stretched_less_than_the_threshold(
    scene: Scene, data: mujoco.MjData
) -> None:
    apo = scene.aponeurosis
    body = apo.shank_bodies[len(apo) // 2]
    _move_vertex_body(scene.model, data, body, np.array([0.0, 0.005, 0.0]))
    assert len(apo.release_by_tearing(data, 0.5, 0.01)) == 0
    assert apo.bound.all()


def test_forces_zero_when_released_positive_when_loaded(scene: Scene, data: mujoco.MjData) -> None:
    model, apo = scene.model, scene.aponeurosis
    released = np.arange(0, len(apo), 3)
    apo.release(data, released, 0.0, ReleaseRule.KNIFE)
    for _ in range(10):
        mujoco.mj_step(model, data)
    forces = apo.forces(data)
    assert forces.shape == (len(apo),)
    assert np.isfinite(forces).all()
    np.testing.assert_array_equal(forces[released], 0.0)
    loaded = np.delete(forces, released)
    assert (loaded > 0).all()  # gravity and the pinned round load every bound one


def test_records_agree_with_released_counts(scene: Scene, data: mujoco.MjData) -> None:
    apo = scene.aponeurosis
    pos, mat, _ = _blade_across_interface(scene)
    knifed = apo.release_by_knife(data, 1.0, apo.under_blade(data, pos, mat, BLADE, 0.003))
    torn = apo.release(data, [0, 1], 2.0, ReleaseRule.TEARING)
    records = apo.records()
    counts = Counter(r.released_by.value for r in records if r.released_by is not None)
    assert apo.released_counts() == {"knife": len(knifed), "tearing": len(torn), "force": 0}
    assert apo.released_counts() == {rule.value: counts[rule.value] for rule in ReleaseRule}
    assert sum(r.released_at_s is not None for r in records) == (~apo.bound).sum()
    assert [r.index for r in records] == list(range(len(apo)))
    for r in records:
        assert (r.round_vertex, r.shank_vertex) == tuple(apo.pairs[r.index])
        assert (r.released_by is None) == (r.released_at_s is None)


def test_reset_binds_everything_again(scene: Scene, data: mujoco.MjData) -> None:
    apo = scene.aponeurosis
    apo.release(data, np.arange(len(apo)), 1.0, ReleaseRule.TEARING)
    assert not data.eq_active[apo.equality_ids].any()
    apo.reset(data)
    assert apo.bound.all()
    assert data.eq_active[apo.equality_ids].all()
    assert all(r.released_by is None for r in apo.records())


def test_release_accepts_a_mask(scene: Scene, data: mujoco.MjData) -> None:
    apo: Aponeurosis = scene.aponeurosis
    mask = np.zeros(len(apo), dtype=bool)
    mask[[2, 5]] = True
    np.testing.assert_array_equal(apo.release(data, mask, 0.1, ReleaseRule.KNIFE), [2, 5])
    assert (~apo.bound).sum() == 2


# --- the binding law and the force rule ---------------------------------------------------------

_TWO_VERTICES = """
<mujoco><option gravity="0 0 0" timestep="0.002" integrator="implicitfast"/>
<worldbody>
  <body name="a" pos="0 -0.0015 0"><joint type="slide" axis="1 0 0"/>
    <joint type="slide" axis="0 1 0"/><joint type="slide" axis="0 0 1"/>
    <geom type="sphere" size="0.001" mass="0.005" contype="0" conaffinity="0"/></body>
  <body name="b" pos="0 0.0015 0"><joint type="slide" axis="1 0 0"/>
    <joint type="slide" axis="0 1 0"/><joint type="slide" axis="0 0 1"/>
    <geom type="sphere" size="0.001" mass="0.005" contype="0" conaffinity="0"/></body>
</worldbody>
<deformable><flex name="pair" dim="1" body="a b" vertex="0 0 0 0 0 0" element="0 1">
  <contact contype="0" conaffinity="0"/></flex></deformable>
</mujoco>"""


def test_a_binding_spring_honours_its_stiffness_in_newtons_per_metre() -> None:
    model = mujoco.MjModel.from_xml_string(_TWO_VERTICES)
    data = mujoco.MjData(model)
    apo = Aponeurosis(model, [0], [1], [model.body("a").id], [model.body("b").id],
                      np.array([[0, 0]]), law=BindingLaw.SPRING, stiffness_n_m=50.0,
                      damping_n_s_m=0.5)
    pull_n = 0.25
    for _ in range(3000):  # 6 s: the dashpot settles the two masses
        data.qfrc_applied[:] = 0.0
        apo.apply_forces(data)
        data.qfrc_applied[4] += pull_n  # b along +y
        data.qfrc_applied[1] -= pull_n  # a along -y
        mujoco.mj_step(model, data)
    stretch = apo.lengths(data)[0] - apo.rest_length_m[0]
    assert pull_n / stretch == pytest.approx(50.0, rel=0.01)
    assert apo.forces(data)[0] == pytest.approx(pull_n, rel=0.01)


def test_force_rule_cuts_only_loaded_bindings_under_the_blade() -> None:
    scene = build_scene(SCENARIO)  # spring law: a binding's force is k times its stretch
    apo = scene.aponeurosis
    data = mujoco.MjData(scene.model)
    mujoco.mj_forward(scene.model, data)
    pos, mat, _ = _blade_across_interface(scene)
    under = apo.under_blade(data, pos, mat, BLADE, SCENARIO.aponeurosis.knife_margin_m)
    stretched = [np.flatnonzero(under)[0], np.flatnonzero(~under)[0]]
    for index in stretched:  # 2 cm: 1 N at 50 N/m
        _move_vertex_body(scene.model, data, apo.shank_bodies[index], np.array([0, 0.02, 0]))
    released = apo.release_by_force(data, 1.0, under, threshold_n=0.5)
    np.testing.assert_array_equal(released, [stretched[0]])
    assert apo.released_by[stretched[0]] is ReleaseRule.FORCE
    assert apo.released_counts() == {"knife": 0, "tearing": 0, "force": 1}


def test_a_hooked_binding_pulls_the_blade_back_with_what_it_pulls_the_vertices() -> None:
    # Hooked at its middle, the binding rides on the blade; moved 1 cm along +x, the blade
    # stretches it: the vertices are pulled towards the hook, the blade back by the same
    # force (the binding's pulls on a and b, summed), about the blade's centre.
    model = mujoco.MjModel.from_xml_string(_TWO_VERTICES)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    apo = Aponeurosis(model, [0], [1], [model.body("a").id], [model.body("b").id],
                      np.array([[0, 0]]), law=BindingLaw.SPRING, stiffness_n_m=50.0,
                      damping_n_s_m=0.0)
    rotation = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    centre = np.array([0.0, 0.0, 0.02])
    apo.track_blade(centre, rotation)
    apo.hook(data, np.array([True]))
    apo.track_blade(centre + np.array([0.01, 0.0, 0.0]), rotation)
    force, moment = apo.apply_forces(data)
    on_vertices = data.qfrc_applied[:6].reshape(2, 3)
    np.testing.assert_allclose(force, -on_vertices.sum(axis=0), atol=1e-12)
    assert on_vertices[0, 0] > 0.0 and on_vertices[1, 0] > 0.0  # towards the hook, +x
    stretch = 2.0 * np.hypot(0.01, 0.0015) - apo.rest_length_m[0]
    assert -force[0] == pytest.approx(50.0 * stretch * 2.0 * 0.01 / np.hypot(0.01, 0.0015))
    arm = np.array([0.0, 0.0, -0.02])  # the hook sits 2 cm below the blade's centre
    np.testing.assert_allclose(moment, np.cross(arm, force), atol=1e-12)
