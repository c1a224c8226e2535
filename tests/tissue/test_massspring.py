"""The anisotropic non-linear mass-spring model: Eq. 8 and 10, the kernel, a block of tissue."""

import math

import mujoco
import numpy as np
import pytest

from cell.errors import MaterialError, MeshError
from cell.sim.scenario import SimulationParams
from cell.tissue.curves import ModulusCurve
from cell.tissue.geometry import MuscleShape, build_two_muscles
from cell.tissue.lattice import tet_edges
from cell.tissue.massspring import MassSpringModel
from cell.tissue.material import MassSpringMaterial
from cell.tissue.tetmesh import TetMesh, structured_hex_tets
from tests.lattice_helpers import lattice_moduli, spring_stiffness

_CELLS = (4, 4, 8)
_SIZE_M = (0.08, 0.08, 0.16)
# The paper's transversely isotropic test material (Fig. 10), Pa.
_EL_PA, _ET_PA = 0.25e6, 0.6e6



def _block(cells: tuple[int, int, int], size_m: tuple[float, float, float]) -> TetMesh:
    axes = [np.linspace(0.0, s, c + 1) for s, c in zip(size_m, cells, strict=True)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return TetMesh.from_arrays(grid, structured_hex_tets(cells), "block")


def _block_model(
    mesh: TetMesh, material: MassSpringMaterial, pinned_bottom: bool
) -> mujoco.MjModel:
    """The block as an elasticity-free flexcomp, with no gravity, after one unrelated slide
    joint (dof 0) that the springs must leave alone."""
    pins = np.flatnonzero(mesh.points[:, 2] == 0.0) if pinned_bottom else []
    pin = f'<pin id="{" ".join(map(str, pins))}"/>' if len(pins) else ""
    return mujoco.MjModel.from_xml_string(
        f"""<mujoco><option gravity="0 0 0" integrator="implicitfast"/><worldbody>
        <body name="other" pos="1 0 0"><joint name="other" type="slide"/>
          <geom size="0.01" contype="0" conaffinity="0"/></body>
        <flexcomp name="block" type="direct" dim="3" radius="0.0001"
          point="{" ".join(f"{v:.9g}" for v in mesh.points.ravel())}"
          element="{" ".join(map(str, mesh.tets.ravel()))}"
          mass="{material.density_kg_m3 * mesh.volume_m3:.9g}">
          <contact contype="0" conaffinity="0"/>{pin}</flexcomp>
        </worldbody></mujoco>"""
    )


def _positions(springs: MassSpringModel, data: mujoco.MjData, rest: np.ndarray) -> np.ndarray:
    """(N, 3) current vertex positions of a block whose parent is the world."""
    free = springs.dofadr >= 0
    moved = rest.copy()
    moved[free] += data.qpos[springs.dofadr[free][:, None] + np.arange(3)]
    return moved


def _static_stretch(material: MassSpringMaterial, stress_pa: float,
                    implicit: bool = False) -> float:
    """Stretch along z of the middle of the block, bottom pinned, top face loaded by a nominal
    stress ``stress_pa`` along z (positive pulls), once at rest; the implicit step runs at
    the scenario's default step, the explicit one at its stable step."""
    mesh = _block(_CELLS, _SIZE_M)
    model = _block_model(mesh, material, pinned_bottom=True)
    springs = MassSpringModel(model, ("block",), material, implicit=implicit,
                              law_refresh_steps=SimulationParams().control_substeps)
    model.opt.timestep = (SimulationParams().timestep_s if implicit
                          else springs.stable_timestep_s())
    data = mujoco.MjData(model)
    z = mesh.points[:, 2]
    top = np.flatnonzero(z == _SIZE_M[2])
    # Nodal share of a uniform traction: a quarter at corners, a half along edges.
    share = np.prod(
        [np.where(np.isin(mesh.points[top, a], (0.0, _SIZE_M[a])), 0.5, 1.0) for a in (0, 1)],
        axis=0,
    )
    bodies = [model.body(f"block_{i}").id for i in top]
    data.xfrc_applied[bodies, 2] = stress_pa * _SIZE_M[0] * _SIZE_M[1] * share / share.sum()
    # Mass-proportional damping at the lowest frequency makes every mode decay at that rate;
    # MuJoCo integrates joint damping implicitly, so it costs no stability.
    stretches = np.linspace(0.5, 2.0, 151)
    modulus = min(
        material.longitudinal.modulus_pa(stretches).min(),
        material.transverse.modulus_pa(stretches).min(),
    )
    omega = math.pi / 2.0 * math.sqrt(modulus / material.density_kg_m3) / _SIZE_M[2]
    model.dof_damping[springs.dofadr[springs.dofadr >= 0][:, None] + np.arange(3)] = (
        2.0 * omega * springs.vertex_mass_kg.max()
    )
    for _ in range(max(math.ceil(15.0 / omega / model.opt.timestep), 200)):
        springs.apply(data)
        mujoco.mj_step(model, data)
    moved = _positions(springs, data, mesh.points)
    assert np.abs(data.qvel).max() < 1e-3 * abs(stress_pa) / modulus * _SIZE_M[2] * omega
    levels = np.unique(z)
    low, high = levels[len(levels) // 4], levels[3 * len(levels) // 4]
    return (moved[z == high, 2].mean() - moved[z == low, 2].mean()) / (high - low)


def test_eq10_with_equal_moduli_is_eq8_exactly() -> None:
    mesh = _block((3, 3, 3), (0.06, 0.06, 0.06))
    points = mesh.points + np.random.default_rng(1).normal(0.0, 2e-3, mesh.points.shape)
    edges, volume = tet_edges(points, mesh.tets)
    d = points[edges[:, 1]] - points[edges[:, 0]]
    eq8 = 3.0e4 * volume / np.einsum("ij,ij->i", d, d)
    eq10 = spring_stiffness(points, edges, volume, 3.0e4, 3.0e4, (0.3, -0.5, 0.8))
    assert np.array_equal(eq10, eq8)


def test_edges_are_unique_and_their_volumes_sum_to_six_volumes() -> None:
    cube = _block((1, 1, 1), (0.1, 0.1, 0.1))
    edges, _ = tet_edges(cube.points, cube.tets)
    # 12 sides, 6 face diagonals, 1 body diagonal.
    assert len(edges) == 19
    muscle = build_two_muscles(MuscleShape(cell_size_m=0.05)).round
    edges, volume = tet_edges(muscle.points, muscle.tets)
    assert len(np.unique(edges, axis=0)) == len(edges)
    assert (edges[:, 0] < edges[:, 1]).all()
    assert volume.sum() == pytest.approx(6.0 * muscle.volume_m3, rel=1e-12)


def test_spring_along_fibres_takes_el_and_across_takes_et() -> None:
    points = np.array([[0, 0, 0], [0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01], [0.01, 0.01, 0]])
    edges = np.array([[0, 1], [0, 2], [0, 3], [0, 4]])
    stiffness = spring_stiffness(points, edges, np.full(4, 1e-6), _EL_PA, _ET_PA, (2, 0, 0))
    area_per_length = 1e-6 / np.array([1e-4, 1e-4, 1e-4, 2e-4])
    mixed = math.sqrt((_EL_PA**2 + _ET_PA**2) / 2.0)
    np.testing.assert_allclose(
        stiffness, area_per_length * [_EL_PA, _ET_PA, _ET_PA, mixed], rtol=1e-12
    )


def test_affine_lattice_of_cubic_cells_is_42_31_stiffer() -> None:
    mesh = _block((4, 4, 4), (0.1, 0.1, 0.1))
    edges, volume = tet_edges(mesh.points, mesh.tets)
    moduli = lattice_moduli(mesh.points, edges, volume, 3.0e4, 3.0e4, (0, 0, 1))
    np.testing.assert_allclose(moduli, 42.0 / 31.0 * 3.0e4, rtol=1e-12)
    material = MassSpringMaterial.isotropic(3.0e4)
    springs = MassSpringModel(_block_model(mesh, material, False), ("block",), material)
    np.testing.assert_allclose(springs.calibration, 31.0 / 42.0, rtol=1e-9)


def test_forces_vanish_at_rest_balance_and_leave_other_dofs_alone() -> None:
    mesh = _block((2, 2, 3), (0.04, 0.04, 0.06))
    material = MassSpringMaterial(
        longitudinal=ModulusCurve((2.5e5, 1e6, 3e6, 0, 0, 0), 0.8, 1.3),
        transverse=ModulusCurve.constant(6e5),
        fibre_direction=(1.0, 1.0, 0.0),
        damping_s=1e-3,
    )
    model = _block_model(mesh, material, pinned_bottom=False)
    springs = MassSpringModel(model, ("block",), material)
    data = mujoco.MjData(model)
    data.qfrc_applied[0] = 7.0
    springs.apply(data)
    assert np.abs(data.qfrc_applied[1:]).max() < 1e-9
    rng = np.random.default_rng(2)
    data.qpos[1:] = rng.normal(0.0, 2e-3, model.nq - 1)
    data.qvel[1:] = rng.normal(0.0, 0.1, model.nv - 1)
    springs.apply(data)
    force = data.qfrc_applied[springs.dofadr[:, None] + np.arange(3)]
    scale = np.abs(force).max()
    assert scale > 1.0
    np.testing.assert_allclose(force.sum(axis=0), 0.0, atol=1e-12 * scale)
    moment = np.cross(_positions(springs, data, mesh.points), force).sum(axis=0)
    np.testing.assert_allclose(moment, 0.0, atol=1e-12 * scale)
    assert data.qfrc_applied[0] == 7.0


def test_uniform_stretch_gives_the_curve_stress_on_every_spring() -> None:
    mesh = _block((2, 2, 2), (0.04, 0.04, 0.04))
    curve = ModulusCurve((3e4, 1.5e5, 5e5, 0, 0, 0), 0.8, 1.3)
    material = MassSpringMaterial(longitudinal=curve, transverse=curve)
    model = _block_model(mesh, material, pinned_bottom=False)
    springs = MassSpringModel(model, ("block",), material)
    data = mujoco.MjData(model)
    for stretch in (0.7, 0.9, 1.2, 1.4):  # inside and beyond the range
        data.qpos[1:] = ((stretch - 1.0) * mesh.points).ravel()
        springs.apply(data)
        # Each spring pulls with its share of the nominal stress: sum(V) / l0 * sigma(r).
        tension = (
            springs.calibration[0]
            * springs.edge_volume_m3
            / springs.rest_lengths_m
            * curve.stress_pa(stretch)
        )
        d = mesh.points[springs.edges[:, 1]] - mesh.points[springs.edges[:, 0]]
        pull = tension[:, None] * d / springs.rest_lengths_m[:, None]
        expected = np.zeros_like(mesh.points)
        np.add.at(expected, springs.edges[:, 0], pull)
        np.add.at(expected, springs.edges[:, 1], -pull)
        got = data.qfrc_applied[springs.dofadr[:, None] + np.arange(3)]
        np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())


@pytest.mark.parametrize("stress_pa", [1.5e3, -1.5e3])
def test_isotropic_block_has_the_material_modulus(stress_pa: float) -> None:
    strain = _static_stretch(MassSpringMaterial.isotropic(3.0e4), stress_pa) - 1.0
    assert stress_pa / strain == pytest.approx(3.0e4, rel=0.06)


@pytest.mark.parametrize("implicit", [False, True], ids=["explicit", "implicit"])
@pytest.mark.parametrize("stress_pa", [1.2e4, -1.2e4])
def test_fibres_along_the_load_take_el_and_across_take_et(stress_pa: float,
                                                           implicit: bool) -> None:
    strains = [
        _static_stretch(
            MassSpringMaterial.transversely_isotropic(_EL_PA, _ET_PA, fibre_direction=fibre),
            stress_pa, implicit,
        )
        - 1.0
        for fibre in ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0))
    ]
    along, across = (stress_pa / s for s in strains)
    assert along / across == pytest.approx(_EL_PA / _ET_PA, rel=0.15)
    assert along == pytest.approx(_EL_PA, rel=0.1)
    assert across == pytest.approx(_ET_PA, rel=0.1)


@pytest.mark.parametrize("implicit", [False, True], ids=["explicit", "implicit"])
def test_nonlinear_block_follows_its_curve(implicit: bool) -> None:
    # Twice as stiff at r = 1.3 as at rest, a third as stiff at r = 0.8.
    coefficients = (3e4, 1e5, 0.0, 0.0, 0.0, 0.0)
    curve = ModulusCurve(coefficients, 0.8, 1.3)
    material = MassSpringMaterial(
        longitudinal=curve,
        transverse=ModulusCurve(tuple(2.0 * c for c in coefficients), 0.8, 1.3),
        fibre_direction=(0.0, 0.0, 1.0),
    )
    # Past 10% compression the block, free at the top, starts to buckle sideways.
    for target in (0.9, 1.1, 1.2, 1.3):
        stress = float(curve.stress_pa(target))
        stretch = _static_stretch(material, stress, implicit)
        assert float(curve.stress_pa(stretch)) == pytest.approx(stress, rel=0.1)


def test_stable_timestep_bounds_the_explicit_springs() -> None:
    mesh = _block((3, 3, 3), (0.06, 0.06, 0.06))
    material = MassSpringMaterial.transversely_isotropic(_EL_PA, _ET_PA)
    model = _block_model(mesh, material, pinned_bottom=True)
    springs = MassSpringModel(model, ("block",), material)
    limit = springs.stable_timestep_s(safety=1.0)
    assert springs.stable_timestep_s() == pytest.approx(0.9 * limit)

    def growth(timestep_s: float) -> float:
        """Largest displacement over the initial one; MuJoCo resets a diverged state, so
        stop as soon as it has grown a thousandfold."""
        model.opt.timestep = timestep_s
        data = mujoco.MjData(model)
        data.qpos[1:] = np.random.default_rng(3).normal(0.0, 1e-5, model.nq - 1)
        largest = 0.0
        for _ in range(400):
            springs.apply(data)
            mujoco.mj_step(model, data)
            largest = max(largest, float(np.abs(data.qpos[1:]).max()) / 1e-5)
            if largest > 1e3:
                break
        return largest

    assert growth(0.95 * limit) < 10.0
    assert growth(1.2 * limit) > 1e3


def test_fibre_direction_changes_at_run_time() -> None:
    mesh = _block((2, 2, 4), (0.04, 0.04, 0.08))
    material = MassSpringMaterial.transversely_isotropic(_EL_PA, _ET_PA)
    model = _block_model(mesh, material, pinned_bottom=True)
    springs = MassSpringModel(model, ("block",), material)
    springs.set_fibre_direction((0.0, 0.0, 5.0))
    turned = MassSpringMaterial.transversely_isotropic(
        _EL_PA, _ET_PA, fibre_direction=(0.0, 0.0, 1.0)
    )
    fresh = MassSpringModel(model, ("block",), turned)
    assert springs.material == turned
    np.testing.assert_allclose(springs.fibre_cosine, fresh.fibre_cosine)
    np.testing.assert_allclose(springs.stiffness_n_m, fresh.stiffness_n_m)
    with pytest.raises(MaterialError) as error:
        springs.set_fibre_direction((0.0, 0.0, 0.0))
    assert error.value.field == "fibre_direction"
    assert springs.material == turned


def test_anisotropy_beyond_the_lattice_is_refused() -> None:
    mesh = _block((2, 2, 2), (0.04, 0.04, 0.04))
    material = MassSpringMaterial.transversely_isotropic(1e6, 1e4)
    with pytest.raises(MaterialError) as error:
        MassSpringModel(_block_model(mesh, material, False), ("block",), material)
    assert error.value.field == "longitudinal"


def test_moving_parent_is_refused() -> None:
    model = mujoco.MjModel.from_xml_string(
        """<mujoco><worldbody><body name="carrier" mocap="true">
        <flexcomp name="block" type="direct" dim="3" mass="1"
          point="0 0 0  0.01 0 0  0 0.01 0  0 0 0.01" element="0 2 1 3"><pin id="0"/>
        </flexcomp></body></worldbody></mujoco>"""
    )
    with pytest.raises(MeshError, match="static"):
        MassSpringModel(model, ("block",), MassSpringMaterial())


def _tip_history(material: MassSpringMaterial, timestep_s: float, implicit: bool,
                 duration_s: float, load_pa: float = 0.0) -> np.ndarray:
    """(steps,) mean x displacement (m) of the top face of the block, bottom pinned, at every
    step: set swinging by an initial velocity, or pulled along z by ``load_pa`` from rest
    (then the z displacement), ramped over 0.1 s, joint damping critical for the first
    mode settling the transient as in :func:`_static_stretch`."""
    mesh = _block(_CELLS, _SIZE_M)
    model = _block_model(mesh, material, pinned_bottom=True)
    springs = MassSpringModel(model, ("block",), material, implicit=implicit,
                              law_refresh_steps=SimulationParams().control_substeps)
    model.opt.timestep = timestep_s
    data = mujoco.MjData(model)
    z = mesh.points[:, 2]
    free = springs.dofadr >= 0
    top = np.flatnonzero(z == _SIZE_M[2])
    axis = 2 if load_pa else 0
    bodies = [model.body(f"block_{i}").id for i in top]
    if load_pa:
        omega = math.pi / 2.0 * math.sqrt(material.transverse.small_strain_modulus_pa
                                          / material.density_kg_m3) / _SIZE_M[2]
        model.dof_damping[springs.dofadr[free][:, None] + np.arange(3)] = (
            2.0 * omega * springs.vertex_mass_kg.max())
    else:  # about the first bending mode's shape
        data.qvel[springs.dofadr[free]] = 0.3 * (z[free] / _SIZE_M[2]) ** 2
    qpos = model.jnt_qposadr[model.body_jntadr[bodies]]
    history = np.empty(round(duration_s / timestep_s))
    for k in range(len(history)):
        ramp = min(1.0, k * timestep_s / 0.1)
        data.xfrc_applied[bodies, 2] = ramp * load_pa * _SIZE_M[0] * _SIZE_M[1] / len(top)
        springs.apply(data)
        mujoco.mj_step(model, data)
        history[k] = data.qpos[qpos + axis].mean()
    return history


def _peaks(history: np.ndarray, timestep_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Times (s, at the end of their step) and values of the local maxima of ``history``."""
    inside = np.flatnonzero((history[1:-1] > history[:-2]) & (history[1:-1] >= history[2:])) + 1
    return (inside + 1) * timestep_s, history[inside]


def test_implicit_free_vibration_keeps_the_explicit_amplitude_and_period() -> None:
    # The default meat swinging at about 2.3 Hz for three periods: the implicit step at the
    # scenario's default keeps the small-step explicit reference's amplitude (the material's
    # damping) and period within 2%: its numerical damping is bounded.
    material = MassSpringMaterial.transversely_isotropic(2.4e4, 1.6e4)
    model = _block_model(_block(_CELLS, _SIZE_M), material, pinned_bottom=True)
    fine = 0.25 * MassSpringModel(model, ("block",), material).stable_timestep_s()
    step = SimulationParams().timestep_s
    reference = _peaks(_tip_history(material, fine, False, 1.5), fine)
    implicit = _peaks(_tip_history(material, step, True, 1.5), step)
    assert len(reference[0]) == len(implicit[0]) == 3
    np.testing.assert_allclose(implicit[1], reference[1], rtol=0.02)
    np.testing.assert_allclose(implicit[0], reference[0], rtol=0.02, atol=step)
    assert implicit[1][-1] <= implicit[1][0]  # no energy gained


def test_implicit_relaxation_follows_the_explicit_reference() -> None:
    # Creep of a viscoelastic block under a constant pull: half the stress relaxes with
    # 0.2 s, so the block lengthens over the second; the implicit step follows the small-step
    # explicit reference within 2% at every sample.
    material = MassSpringMaterial.isotropic(3.0e4, relaxation_weights=(0.5,),
                                            relaxation_times_s=(0.2,))
    model = _block_model(_block(_CELLS, _SIZE_M), material, pinned_bottom=True)
    fine = 0.5 * MassSpringModel(model, ("block",), material).stable_timestep_s()
    step = SimulationParams().timestep_s
    reference = _tip_history(material, fine, False, 1.0, load_pa=1.5e3)
    implicit = _tip_history(material, step, True, 1.0, load_pa=1.5e3)
    times = np.array([0.25, 0.5, 0.75, 1.0])
    at_reference = reference[np.round(times / fine).astype(int) - 1]
    at_implicit = implicit[np.round(times / step).astype(int) - 1]
    assert at_reference[-1] > 1.3 * at_reference[0]  # it creeps
    np.testing.assert_allclose(at_implicit, at_reference, rtol=0.02)
