"""The fine, slow reference of the specimen tests: the whole specimen mesh in MuJoCo, in time.

:mod:`cell.diagnosis.specimen.solve` simulates a test quasi-statically on a homogeneous lattice;
this module runs the same springs (:class:`~cell.tissue.massspring.MassSpringModel`, calibrated like
the specimen's lattice, with their fibres along the load axis) on every vertex of a tet mesh of the
specimen (:func:`~cell.diagnosis.specimen.solve.specimen_mesh`) in a MuJoCo flexcomp, in dynamics,
to show what the quasi- static choice changes. The platens are lubricated as there: the bottom face
is held along z (one corner also in x and y, against drift), the top face follows the test's
displacement history along z, and both slide freely. The result is the axial force on the top face
at the test's sample times (positive pulls).

The material runs as in the cell, each on MuJoCo's semi-implicit ``Euler`` (dof damping
implicit, material forces explicit):

- :class:`~cell.tissue.material.MassSpringMaterial`: an elasticity-free flex with
  :class:`~cell.tissue.massspring.MassSpringModel` springs, fibres at the test's ``angle_deg`` from
  the load axis z, in the x-z plane.
- :class:`~cell.tissue.material.ContinuumMaterial`: MuJoCo's own flex elasticity. ``discrete``, the
  cell's integrator for it, is no use here: its implicit step moves the driven top face back
  towards rest within the step (whatever its mass), and the interior never follows.

The faces are driven by writing their vertices' slide ``qpos`` and ``qvel`` before every step.
A mocap or moving parent is ruled out (the springs need a static parent, and pinned vertices
stay at rest); an equality or actuator drive would add its own compliance to the measured force.
Written states are exact, cost nothing, and the reaction is the material's force on those
vertices, read straight from ``qfrc_applied`` (springs) and ``qfrc_passive`` (flex elasticity).

Speed: the tests are quasi-static and last up to minutes, and explicit material forces bound the
step by the vertex masses. Mass scaling (a heavier specimen in real time) lengthens the step
while keeping the time axis, and so every rate-dependent part of the material, real. The scale
is as large as an inertia budget allows: the stress wave that the test's largest change of
strain rate launches, ``sqrt(E rho) * height * d(rate)``, stays below ``inertia_tolerance`` of
``E * strain range``, with E the material's softest modulus over the test's strains. Dof
damping at ``damping_ratio`` of the lowest axial mode takes out the ringing. Each run reports
its inertia ratio (net force on the free vertices, zero at equilibrium, over the largest top
force) and its smallest tet volume ratio (<= 0 once the mesh has inverted).

Example:
    >>> from cell.measure.specimens import load_measurement_set
    >>> from cell.tissue.material import MassSpringMaterial
    >>> data = load_measurement_set("assets/measured/beef_round_example")
    >>> run = simulate_meshed(data.test("t00"), data.specimen, MassSpringMaterial.isotropic(6e3))
    >>> run.force_n.shape, run.inertia_ratio < 0.01
    ((250,), True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from cell.diagnosis.specimen.solve import fibre_direction, specimen_mesh
from cell.errors import DivergenceError
from cell.measure.specimens import MechanicalTest, Specimen
from cell.tissue.flexcomp import flexcomp_xml, set_continuum_law
from cell.tissue.massspring import MassSpringModel
from cell.tissue.material import ContinuumMaterial, MassSpringMaterial
from cell.tissue.tetmesh import TetMesh, signed_volumes_m3

Material = MassSpringMaterial | ContinuumMaterial

_FLEX = "specimen"
# Moduli sampled over a test's stretches to find the softest one.
_MODULUS_SAMPLES = 65
# Central-difference step of the continuum's stiffness, relative to the specimen's height.
_PROBE = 1e-6
_TINY = float(np.finfo(float).tiny)


@dataclass(frozen=True)
class SpecimenSimParams:
    """How a test is simulated: mesh, time step and mass scaling.

    Attributes:
        cells: tet cells along the longest edge of the specimen (the others in proportion, at
            least 1).
        inertia_tolerance: inertial stress budget, as a fraction of the test's stress range,
            that sets the mass scale (module docstring).
        max_mass_scale: upper bound on the mass scale; 1 simulates the real specimen.
        damping_ratio: damping of the lowest axial mode by mass-proportional dof damping.
        timestep_safety: fraction of the stable explicit step taken.

    Raises:
        ValueError: a parameter out of range.

    Example:
        >>> reference = SpecimenSimParams(max_mass_scale=1.0, timestep_safety=0.45)
    """

    cells: int = 4
    inertia_tolerance: float = 0.005
    max_mass_scale: float = 1.0e6
    damping_ratio: float = 0.5
    timestep_safety: float = 0.9

    def __post_init__(self) -> None:
        if self.cells < 1:
            raise ValueError(f"cells must be >= 1, got {self.cells}")
        for name in ("inertia_tolerance", "damping_ratio"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not self.max_mass_scale >= 1:
            raise ValueError(f"max_mass_scale must be >= 1, got {self.max_mass_scale}")
        if not 0 < self.timestep_safety <= 1:
            raise ValueError(f"timestep_safety must be in (0, 1], got {self.timestep_safety}")


@dataclass(frozen=True, eq=False)
class MeshedRun:
    """The simulated force of one test, and how it was simulated.

    Attributes:
        test_id: the measured test's id.
        time_s: (n,) the test's sample times, s.
        force_n: (n,) simulated axial force on the top face at those times, N (+ pulls).
        mass_scale: simulated specimen mass over its real mass.
        timestep_s: simulation step, s.
        steps: number of steps taken.
        inertia_ratio: largest net force on the free vertices (inertia plus dof damping) over
            the largest top force; small when the run is quasi-static.
        min_volume_ratio: smallest tet volume over its rest volume at the sample times; <= 0
            when the mesh has inverted.

    The module's example makes one (a run takes seconds: MuJoCo steps the test's whole time).
    """

    test_id: str
    time_s: np.ndarray
    force_n: np.ndarray
    mass_scale: float
    timestep_s: float
    steps: int
    inertia_ratio: float
    min_volume_ratio: float


@dataclass(frozen=True, eq=False)
class _Dofs:
    """Where the specimen's vertices live in ``qpos``/``qvel``.

    ``top_z``: the driven z dofs of the top face; ``bottom_z``: the held z dofs of the bottom
    face; ``free``: every other dof (the faces' x and y included); ``free_z``: the interior's z
    dofs; ``mass`` and ``mass_z``: their masses per dof; ``vertex``: each vertex's first dof,
    -1 when pinned.
    """

    top_z: np.ndarray
    bottom_z: np.ndarray
    free: np.ndarray
    free_z: np.ndarray
    mass: np.ndarray
    mass_z: np.ndarray
    vertex: np.ndarray

    @classmethod
    def of(cls, model: mujoco.MjModel, mesh: TetMesh) -> _Dofs:
        bodies = model.flex_vertbodyid[model.flex_vertadr[0] :][: len(mesh.points)]
        vertex = np.where(model.body_dofnum[bodies] > 0, model.body_dofadr[bodies], -1)
        moving = vertex >= 0
        top = (mesh.points[:, 2] == mesh.points[:, 2].max()) & moving
        bottom = (mesh.points[:, 2] == 0.0) & moving
        inside = moving & ~top & ~bottom
        held = np.zeros((len(vertex), 3), dtype=bool)
        held[top | bottom, 2] = True
        free = moving[:, None] & ~held
        dof = vertex[:, None] + np.arange(3)
        return cls(
            top_z=vertex[top] + 2,
            bottom_z=vertex[bottom] + 2,
            free=dof[free],
            free_z=vertex[inside] + 2,
            mass=np.broadcast_to(model.body_mass[bodies][:, None], held.shape)[free],
            mass_z=model.body_mass[bodies[inside]],
            vertex=vertex,
        )

    def positions(self, data: mujoco.MjData, rest: np.ndarray) -> np.ndarray:
        """(N, 3) vertex positions: slide joints along the world axes, one qpos per dof."""
        moved = rest.copy()
        free = self.vertex >= 0
        moved[free] += data.qpos[self.vertex[free][:, None] + np.arange(3)]
        return moved


def specimen_model(mesh: TetMesh, material: Material, mass_kg: float) -> mujoco.MjModel:
    """The specimen as a flexcomp, the corner at the origin pinned, no gravity, no contacts."""
    corner = int(np.argmin(np.linalg.norm(mesh.points, axis=1)))
    flex = flexcomp_xml(_FLEX, mesh.points, mesh.tets, material, mass_kg, radius_m=0.0001,
                        contact='contype="0" conaffinity="0" selfcollide="none"',
                        pins=[corner])
    spec = mujoco.MjSpec.from_string(
        f"""<mujoco><option gravity="0 0 0" integrator="Euler">
        <flag contact="disable"/></option><worldbody>{flex}</worldbody></mujoco>"""
    )
    set_continuum_law(spec, material)
    return spec.compile()


def softest_modulus_pa(material: Material, strain: np.ndarray) -> float:
    """Smallest tangent modulus of the material over the test's nominal strains, Pa."""
    if isinstance(material, ContinuumMaterial):
        return material.young_pa
    stretch = 1.0 + np.linspace(min(strain.min(), 0.0), max(strain.max(), 0.0), _MODULUS_SAMPLES)
    return float(min(material.longitudinal.modulus_pa(stretch).min(),
                     material.transverse.modulus_pa(stretch).min()))


def inertia_mass_scale(time_s: np.ndarray, strain: np.ndarray, height_m: float, modulus_pa: float,
                density_kg_m3: float, params: SpecimenSimParams) -> float:
    """Largest mass scale whose inertial stress stays within budget (module docstring).

    Keeping ``sqrt(E rho) * height * d(rate)`` below ``tolerance * E * range`` bounds the
    density at ``E * (tolerance * range / (height * d(rate)))**2``.
    """
    interval = np.diff(time_s)
    rate = np.divide(np.diff(strain), interval, out=np.zeros(len(interval)), where=interval > 0)
    # The test starts and ends at rest.
    rate_change = max(float(np.abs(np.diff(rate, prepend=0.0, append=0.0)).max()), _TINY)
    strain_range = max(float(np.ptp(strain)), _TINY)
    density = modulus_pa * (params.inertia_tolerance * strain_range / (height_m * rate_change)) ** 2
    return float(np.clip(density / density_kg_m3, 1.0, params.max_mass_scale))


def _continuum_stable_timestep_s(model: mujoco.MjModel, data: mujoco.MjData, dofs: _Dofs,
                                 damping_s: float, height_m: float) -> float:
    """Largest stable explicit step of MuJoCo's flex elasticity at rest, s.

    The stiffness of the free dofs comes from central differences of ``qfrc_spring``; its
    highest frequency w bounds semi-implicit Euler with Rayleigh damping tau at
    ``sqrt(tau**2 + 4 / w**2) - tau``, as for the springs
    (:meth:`~cell.tissue.massspring.MassSpringModel.stable_timestep_s`).
    """
    probe = _PROBE * height_m
    stiffness = np.empty((len(dofs.free), len(dofs.free)))
    for column, dof in enumerate(dofs.free):
        pulls = []
        for offset in (probe, -probe):
            data.qpos[dof] = offset
            mujoco.mj_forward(model, data)
            pulls.append(data.qfrc_spring[dofs.free].copy())
        data.qpos[dof] = 0.0
        stiffness[:, column] = (pulls[1] - pulls[0]) / (2.0 * probe)
    weight = dofs.mass**-0.5
    omega_sq = float(np.linalg.eigvalsh(weight[:, None] * stiffness * weight[None, :]).max())
    return math.sqrt(damping_s**2 + 4.0 / omega_sq) - damping_s


def simulate_meshed(
    test: MechanicalTest,
    specimen: Specimen,
    material: Material,
    params: SpecimenSimParams | None = None,
) -> MeshedRun:
    """Simulate ``test`` on ``specimen`` made of ``material`` (module docstring).

    The specimen's density sets its mass (the material's is not used); a mass-spring
    material's fibres are turned to the test's angle.

    Raises:
        MaterialError: a mass-spring anisotropy the mesh's springs cannot give.
        DivergenceError: the simulation blew up.

    The module's example runs one test.
    """
    params = SpecimenSimParams() if params is None else params
    height = specimen.size_m[2]
    mesh = specimen_mesh(specimen, params.cells)
    time = test.time_s - test.time_s[0]
    strain = test.strain(specimen)
    modulus = softest_modulus_pa(material, strain)
    mass_scale = inertia_mass_scale(time, strain, height, modulus, specimen.density_kg_m3, params)
    model = specimen_model(mesh, material, specimen.density_kg_m3 * mass_scale * mesh.volume_m3)
    data = mujoco.MjData(model)
    dofs = _Dofs.of(model, mesh)
    springs = None
    if isinstance(material, MassSpringMaterial):
        turned = replace(material, fibre_direction=fibre_direction(test.angle_deg))
        springs = MassSpringModel(model, (_FLEX,), turned, calibrate_along=(0.0, 0.0, 1.0))
        stable = springs.stable_timestep_s(safety=1.0)
    else:
        stable = _continuum_stable_timestep_s(model, data, dofs, material.damping_s, height)
    timestep = params.timestep_safety * stable
    model.opt.timestep = timestep
    # Lowest axial mode of a bar held at both ends; Euler integrates dof damping implicitly.
    omega = math.pi / height * math.sqrt(modulus / (specimen.density_kg_m3 * mass_scale))
    drag_rate = 2.0 * params.damping_ratio * omega
    model.dof_damping[dofs.free] = drag_rate * dofs.mass

    steps = math.ceil(float(time[-1]) / timestep) + 1
    grid = np.arange(steps + 1) * timestep
    drive = np.interp(grid, time, test.displacement_m)
    speed = np.diff(drive) / timestep
    sampled = np.zeros(steps, dtype=bool)
    sampled[np.minimum(np.searchsorted(grid, time), steps - 1)] = True
    rest_volume = signed_volumes_m3(mesh.points, mesh.tets)
    force = np.empty(steps)
    momentum = np.zeros(steps + 1)
    min_volume_ratio = 1.0
    for k in range(steps):
        data.qpos[dofs.bottom_z] = 0.0
        data.qvel[dofs.bottom_z] = 0.0
        data.qpos[dofs.top_z] = drive[k]
        data.qvel[dofs.top_z] = speed[k]
        if springs is not None:
            springs.apply(data)
        if sampled[k]:
            volume = signed_volumes_m3(dofs.positions(data, mesh.points), mesh.tets)
            min_volume_ratio = min(min_volume_ratio, float((volume / rest_volume).min()))
        mujoco.mj_step(model, data)
        # Both fields now hold the material's forces at the state the step started from.
        force[k] = -(data.qfrc_applied[dofs.top_z].sum() + data.qfrc_passive[dofs.top_z].sum())
        momentum[k + 1] = dofs.mass_z @ data.qvel[dofs.free_z]
    finite = np.isfinite(force)
    if not finite.all() or data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number:
        at = float(grid[np.argmin(finite)]) if not finite.all() else float(grid[-1])
        raise DivergenceError(at, f"test {test.test_id!r}: the specimen's state is not finite")
    # Net force on the free vertices along z: inertia plus the implicit dof damping.
    net = np.diff(momentum) / timestep + drag_rate * momentum[1:]
    return MeshedRun(
        test_id=test.test_id,
        time_s=test.time_s,
        force_n=np.interp(time, grid[:-1], force),
        mass_scale=mass_scale,
        timestep_s=timestep,
        steps=steps,
        inertia_ratio=float(np.abs(net).max()) / max(float(np.abs(force).max()), _TINY),
        min_volume_ratio=min_volume_ratio,
    )
