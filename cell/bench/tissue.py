"""``musclecell bench tissue``: every tissue model on the two bound muscles, side by side.

Each model runs on the cell's two muscles without the robots (the scene of :func:`build_scene`
less the arms, :func:`cell.bench.cell.tissue_only_model`), with the aponeurosis as binding springs
and the shank standing on the table, at three mesh sizes. Per model and size it reports:

- ``us_per_node_step``: wall time of one step (the runtime's forces, then ``mj_step``) per
  tissue node, ``time.perf_counter``, best of three repetitions after a warm-up, the
  repetitions of all the runs of a size interleaved (:func:`best_step_times`); the same by
  the process's CPU time as ``cpu_us_per_node_step``, to tell a busy machine;
- ``stable_timestep_s``: the largest step that a short run from rest survives (bisection; no
  NaN, no fatal MuJoCo warning, no tissue faster than the scenario's limit), capped; for the
  mass-spring models also :meth:`MassSpringModel.stable_timestep_s` (``safety=1``);
- ``real_time_factor``: simulated over wall time at ``run_timestep_s``, 0.9 times the stable
  step (the runtime's own safety factor);
- ``force_error_pct``: the realism figure, the reaction force of a tension test on a cube meshed
  at the same cell size (:func:`tension_force_n`), against the same model's converged force,
  extrapolated from three fine meshes (:func:`extrapolated_force_n`). Against its own limit,
  so that it measures what the mesh costs; how far the models' limits lie apart (model error:
  a spring lattice's fixed Poisson ratio, StVK against neo-Hookean) is in their reference
  forces;
- ``ratio_to_numpy``: ``us_per_node_step`` over that of a plain numpy mass-spring integrator
  measured in the same run on the same mesh (:class:`NumpyMassSpring`), the MATLAB-style peer.

Peers, timed the same way: :class:`NumpyMassSpring`, and MuJoCo's stock flex (``<elasticity>``,
bindings as ``connect`` equalities, MuJoCo's default solver options; :func:`stock_flex_run`).
The paper's Table 1 figures are carried as constants, not measured here. The targets: the
non-linear anisotropic model at most 1 us per node and step at about 1000 nodes, and real time
at about 2000 nodes with :func:`default_meat` and with the paper's Fig. 10 moduli (and its
D = 0.1 N s/m, :func:`paper_damping_s`), each at its own stable step. One thread: MuJoCo has no
thread pool here and the spring kernel is serial numba.

Example:
    >>> report = run_tissue_bench(TissueBenchParams.quick())  # doctest: +SKIP
    >>> report["targets"]["us_per_node_step_1000_nodes"]["pass"]  # doctest: +SKIP
"""

from __future__ import annotations

import math
import os
import platform
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, replace
from typing import Any, Literal

import mujoco
import numpy as np
from scipy.optimize import brentq

from cell.bench.cell import cpu_count, tissue_only_model
from cell.errors import DivergenceError
from cell.sim.assembly import build_scene, integrator
from cell.sim.scenario import Scenario, SimulationParams
from cell.sim.simulation import FATAL_WARNINGS
from cell.tissue.aponeurosis import Aponeurosis
from cell.tissue.flexcomp import flexcomp_xml
from cell.tissue.geometry import MuscleShape
from cell.tissue.massspring import MassSpringModel
from cell.tissue.material import ContinuumMaterial, MassSpringMaterial, default_meat
from cell.tissue.tetmesh import TetMesh, structured_hex_tets

#: The paper's Table 1 (Nabil et al. 2015, Core 2 Duo 3 GHz), wall time per node per iteration,
#: in microseconds. Quoted for comparison; NOT measured here.
PAPER_TABLE_1_US = {
    "mass_spring_matlab": 502.0,
    "mass_spring_sofa": 110.0,
    "tensor_mass_matlab": 430.0,
    "tensor_mass_sofa": 141.0,
}
#: The paper's dashpot per spring (Fig. 8), N s/m.
PAPER_SPRING_DAMPING_N_S_M = 0.1
_MUSCLES = ("round", "shank")
# The runtime refuses steps above 0.9 times the springs' stable step; the bench runs there too.
_RUN_SAFETY = 0.9
# Mass given to the displaced face of the tension test: the solver then cannot move it.
_HELD_MASS_KG = 1e6


@dataclass(frozen=True)
class TissueModel:
    """One tissue model of the bench.

    Attributes:
        key: identifier in the JSON report.
        label: what it is, for the tables.
        material: its material (the family follows from the type).

    Example:
        >>> TissueModel("linear", "StVK continuum", ContinuumMaterial()).family
        'continuum'
    """

    key: str
    label: str
    material: ContinuumMaterial | MassSpringMaterial

    @property
    def family(self) -> Literal["continuum", "mass_spring"]:
        """``"continuum"`` (MuJoCo's flex elasticity) or ``"mass_spring"`` (ours)."""
        return "continuum" if isinstance(self.material, ContinuumMaterial) else "mass_spring"


def tissue_models() -> tuple[TissueModel, ...]:
    """The six models the bench compares.

    The continuum models keep the paper's E = 0.03 MPa (ContinuumMaterial's default); the
    plastic one yields at 5% strain, so that the 10% tension test flows. The linear mass-spring
    models take the small-strain moduli of :func:`default_meat` (isotropic: the paper's
    0.03 MPa), so that anisotropy and non-linearity are the only differences between them.

    Example:
        >>> [m.key for m in tissue_models()][:2]
        ['continuum_linear', 'continuum_nonlinear']
    """
    meat = default_meat()
    el = meat.longitudinal.small_strain_modulus_pa
    et = meat.transverse.small_strain_modulus_pa
    return (
        TissueModel("continuum_linear", "continuum StVK", ContinuumMaterial(law="stvk")),
        TissueModel("continuum_nonlinear", "continuum neo-Hookean",
                    ContinuumMaterial(law="neo_hookean")),
        TissueModel("continuum_plastic", "continuum StVK + von Mises (yield 5%)",
                    ContinuumMaterial(law="stvk", yield_strain=0.05)),
        TissueModel("mass_spring_isotropic", "mass-spring isotropic 30 kPa",
                    MassSpringMaterial.isotropic(3.0e4)),
        TissueModel("mass_spring_anisotropic", "mass-spring anisotropic linear 24/16 kPa",
                    MassSpringMaterial.transversely_isotropic(el, et)),
        TissueModel("mass_spring_nonlinear_anisotropic",
                    "mass-spring non-linear anisotropic (default meat)", meat),
    )


def paper_fig10_material(damping_s: float = 2.0e-4) -> MassSpringMaterial:
    """The paper's Fig. 10 test material: El = 0.25 MPa, Et = Er = 0.6 MPa, linear springs,
    fibres along x, the given damping time (s; see :func:`paper_damping_s`).

    Example:
        >>> paper_fig10_material().transverse.small_strain_modulus_pa
        600000.0
    """
    return MassSpringMaterial.transversely_isotropic(0.25e6, 0.6e6, damping_s=damping_s)


def paper_damping_s(material: MassSpringMaterial, cell_size_m: float) -> float:
    """The paper's D = 0.1 N s/m per spring as this material's damping time on the muscles of
    ``cell_size_m`` (s): D over the median spring stiffness (``damping_s = D / K``).

    Example:
        >>> paper_damping_s(paper_fig10_material(), 0.025)  # doctest: +SKIP
        4.5e-05
    """
    run = TissueRun(_scenario(material, cell_size_m, 0.002))
    stiffness = np.concatenate([springs.stiffness_n_m for springs in run.springs])
    return PAPER_SPRING_DAMPING_N_S_M / float(np.median(stiffness))


@dataclass(frozen=True)
class TissueBenchParams:
    """What the bench runs and how long.

    Attributes:
        cell_sizes_m: muscle mesh cell sizes (:class:`MuscleShape`); 0.05, 0.028 and 0.0165 m
            give 240, 990 and 3944 nodes.
        realtime_cell_size_m: mesh of the real-time targets (0.021 m: 2070 nodes); ``None``
            skips them.
        max_timestep_s: cap of the stable step search, s.
        stability_steps: steps of each trial run of the stable step search.
        stability_tolerance: relative width at which the search stops.
        warmup_steps: steps before timing (the muscles settle on the table).
        timing_steps: steps per timed repetition at the smallest size; larger meshes run
            proportionally fewer, at least ``min_timing_steps``.
        min_timing_steps: fewest steps per timed repetition.
        repetitions: timed repetitions, interleaved across the runs of a size; the best
            counts.
        block_side_m: edge of the tension test cube, m.
        block_strain: displacement of its top face over its height.
        reference_cells: cells per edge of the three fine meshes of the tension test whose
            forces are extrapolated to the reference (:func:`extrapolated_force_n`).

    Example:
        >>> TissueBenchParams.quick().cell_sizes_m
        (0.05,)
    """

    cell_sizes_m: tuple[float, ...] = (0.05, 0.028, 0.0165)
    realtime_cell_size_m: float | None = 0.021
    max_timestep_s: float = 0.01
    stability_steps: int = 300
    stability_tolerance: float = 0.05
    warmup_steps: int = 100
    timing_steps: int = 400
    min_timing_steps: int = 30
    repetitions: int = 3
    block_side_m: float = 0.1
    block_strain: float = 0.1
    reference_cells: tuple[int, int, int] = (8, 12, 16)

    @classmethod
    def quick(cls) -> TissueBenchParams:
        """The smallest mesh only, short runs, a coarse reference: a smoke test."""
        return cls(cell_sizes_m=(0.05,), realtime_cell_size_m=None, stability_steps=60,
                   stability_tolerance=0.25, warmup_steps=20, timing_steps=40,
                   min_timing_steps=10, reference_cells=(3, 4, 6))


def _scenario(material: ContinuumMaterial | MassSpringMaterial, cell_size_m: float,
              timestep_s: float) -> Scenario:
    """The default scenario with this material and mesh; the step is set later, per run."""
    return Scenario(tissue=MuscleShape(cell_size_m=cell_size_m), material=material,
                    simulation=SimulationParams(timestep_s=timestep_s))


class TissueRun:
    """The runtime's physics step on the two muscles without the robots.

    Before every ``mj_step`` it writes what :meth:`cell.sim.simulation.Simulation.step` writes: the
    mass-spring forces (one :class:`MassSpringModel` per muscle) and the binding springs. It
    cannot be a :class:`~cell.sim.simulation.Simulation`: that one needs the knife and the sensors
    of the arms. With ``runtime_forces=False`` only MuJoCo acts (the stock flex peer).

    Attributes:
        model: the compiled scene less the arms.
        data: the state.
        nodes: tissue vertices, pinned ones included.

    Example:
        >>> run = TissueRun(Scenario(tissue=MuscleShape(cell_size_m=0.05)))
        >>> run.model.opt.timestep = 0.002
        >>> run.step(10)
        >>> run.divergence() is None
        True
    """

    def __init__(self, scenario: Scenario, runtime_forces: bool = True) -> None:
        scene = build_scene(scenario)
        self.model = tissue_only_model(scenario)
        bodies = np.concatenate([scene.round_bodies, scene.shank_bodies])
        # tissue_only_model deletes the arms, which come after the tissue: ids must not move.
        if any(self.model.body(int(b)).name != scene.model.body(int(b)).name for b in bodies):
            raise RuntimeError("the scene less its arms renumbered the tissue bodies")
        self.nodes = scene.node_count
        self.speed_limit_m_s = scenario.simulation.max_tissue_speed_m_s
        free = np.unique(bodies[self.model.body_dofnum[bodies] > 0])
        self._dofs = (self.model.body_dofadr[free][:, None] + np.arange(3)).ravel()
        self.springs: list[MassSpringModel] = []
        self.aponeurosis: Aponeurosis | None = None
        if runtime_forces:
            if isinstance(scenario.material, MassSpringMaterial):
                self.springs = [MassSpringModel(self.model, (muscle,), scenario.material)
                                for muscle in _MUSCLES]
            apo = scene.aponeurosis
            self.aponeurosis = Aponeurosis(
                self.model, apo.round_vertices, apo.shank_vertices, apo.round_bodies,
                apo.shank_bodies, apo.pairs, law=apo.law, stiffness_n_m=apo.stiffness_n_m,
                damping_n_s_m=apo.damping_n_s_m, equality_ids=apo.equality_ids)
        self.data = mujoco.MjData(self.model)

    def formula_timestep_s(self) -> float | None:
        """The springs' own stable step (``safety=1``), s; None without springs."""
        if not self.springs:
            return None
        return min(springs.stable_timestep_s(safety=1.0) for springs in self.springs)

    def reset(self, state: mujoco.MjData | None = None) -> None:
        """Back to rest (a fresh state: no warnings counted), or to a copy of ``state``."""
        self.data = mujoco.MjData(self.model)
        if state is not None:
            mujoco.mj_copyData(self.data, self.model, state)

    def step(self, count: int = 1) -> None:
        """``count`` physics steps with the runtime's forces; no divergence check."""
        data, model = self.data, self.model
        for _ in range(count):
            if not self.springs:
                data.qfrc_applied[self._dofs] = 0.0
            for springs in self.springs:
                springs.apply(data)
            if self.aponeurosis is not None:
                self.aponeurosis.apply_forces(data)
            mujoco.mj_step(model, data)

    def divergence(self) -> str | None:
        """Why the state is no longer data (the runtime's checks), or None."""
        data = self.data
        fired = [w.name for w in FATAL_WARNINGS if data.warning[w].number > 0]
        if fired:
            return f"MuJoCo warning {', '.join(fired)}"
        if not (np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()):
            return "non-finite position or velocity"
        speed = float(np.abs(data.qvel[self._dofs]).max(initial=0.0))
        if speed > self.speed_limit_m_s:
            return f"tissue speed {speed:.3g} m/s"
        return None

    def survives(self, timestep_s: float, steps: int) -> bool:
        """Whether ``steps`` steps of ``timestep_s`` from rest stay finite and slow."""
        self.model.opt.timestep = timestep_s
        self.reset()
        for _ in range(steps):
            self.step()
            if self.divergence() is not None:
                return False
        return True


def largest_stable_timestep_s(survives: Callable[[float], bool], guess_s: float, cap_s: float,
                              tolerance: float) -> tuple[float, bool]:
    """Largest step (s) for which ``survives`` holds, to a relative ``tolerance``, and whether
    it is the cap ``cap_s``.

    Brackets from ``guess_s`` by factors of 1.25, then bisects in log scale. Assumes one
    threshold: every step below a surviving one survives.

    Example:
        >>> largest_stable_timestep_s(lambda h: h < 3e-3, 1e-3, 1e-2, 0.01)[0] < 3e-3
        True
    """
    if survives(cap_s):
        return cap_s, True
    grow = 1.25
    x = min(guess_s, cap_s / grow)
    if survives(x):
        low, high = x, cap_s
        while x * grow < high:
            x *= grow
            if not survives(x):
                high = x
                break
            low = x
    else:
        high = x
        while not survives(x := x / grow):
            high = x
            if x < 1e-7:
                raise DivergenceError(0.0, f"unstable at every step down to {x:.3g} s")
        low = x
    while high / low > 1.0 + tolerance:
        middle = math.sqrt(low * high)
        low, high = (middle, high) if survives(middle) else (low, middle)
    return low, False


@dataclass(frozen=True)
class StepTime:
    """Time of one step, s: ``wall_s`` by ``time.perf_counter`` (the figure reported), and
    ``cpu_s``, this process's CPU time, which other processes on the machine do not inflate:
    where the two differ, the machine was busy."""

    wall_s: float
    cpu_s: float


@dataclass(frozen=True)
class TimingJob:
    """One thing to time: ``step(n)`` runs n steps from the state that ``reset()`` restores;
    a repetition runs ``steps`` of them."""

    step: Callable[[int], None]
    reset: Callable[[], None]
    steps: int


def best_step_times(jobs: Sequence[TimingJob], repetitions: int) -> list[StepTime]:
    """Best over ``repetitions`` of each job's time per step.

    The repetitions interleave (the first of every job, then the second, ...): on a shared
    machine slow and fast spells last seconds, longer than a repetition, and interleaving
    spreads each job's repetitions over them all and gives every job the same conditions.
    The fastest repetition is the one the machine disturbed least.

    Example:
        >>> job = TimingJob(lambda n: None, lambda: None, 10)
        >>> best_step_times([job, job], 3)[1].wall_s < 1e-3
        True
    """
    wall = [math.inf] * len(jobs)
    cpu = [math.inf] * len(jobs)
    for _ in range(repetitions):
        for k, job in enumerate(jobs):
            job.reset()
            start, start_cpu = time.perf_counter(), time.process_time()
            job.step(job.steps)
            wall[k] = min(wall[k], time.perf_counter() - start)
            cpu[k] = min(cpu[k], time.process_time() - start_cpu)
    return [StepTime(w / job.steps, c / job.steps) for w, c, job in zip(wall, cpu, jobs,
                                                                          strict=True)]


class NumpyMassSpring:
    """The MATLAB-style peer: the same springs, bindings and masses, integrated with plain
    vectorised numpy (semi-implicit Euler), no MuJoCo.

    Linear spring-dampers with :class:`MassSpringModel`'s edges, rest lengths and small-strain
    stiffnesses and its damping time; the binding springs of the aponeurosis; gravity; the
    table as a clamp (a vertex below it is put back on it and loses its downward speed).
    Pinned vertices stay put.

    Example:
        >>> peer = NumpyMassSpring(TissueRun(Scenario(tissue=MuscleShape(cell_size_m=0.05))))
        >>> peer.step(10, 0.002)
        >>> bool(np.isfinite(peer.position).all())
        True
    """

    def __init__(self, run: TissueRun) -> None:
        if not run.springs or run.aponeurosis is None:
            raise ValueError("the peer copies a mass-spring run with binding springs")
        data = mujoco.MjData(run.model)
        mujoco.mj_kinematics(run.model, data)
        mujoco.mj_flex(run.model, data)
        rest, edges, lengths, stiffness, mass = [], [], [], [], []
        offset = 0
        for muscle, springs in zip(_MUSCLES, run.springs, strict=True):
            flex = mujoco.mj_name2id(run.model, mujoco.mjtObj.mjOBJ_FLEX, muscle)
            first, count = int(run.model.flex_vertadr[flex]), int(run.model.flex_vertnum[flex])
            # Bindings name global flex vertices: the peer's vertices must be in that order.
            if first != offset:
                raise ValueError("the muscles' flex vertices are not round then shank")
            rest.append(data.flexvert_xpos[first:first + count].copy())
            edges.append(springs.edges + offset)
            lengths.append(springs.rest_lengths_m)
            stiffness.append(springs.stiffness_n_m)
            mass.append(springs.vertex_mass_kg)
            offset += count
        self._rest = np.concatenate(rest)
        self._i, self._j = np.concatenate(edges).T
        self._length = np.concatenate(lengths)
        self._stiffness = np.concatenate(stiffness)
        self._damping_s = run.springs[0].material.damping_s
        mass = np.concatenate(mass)
        # Pinned vertices (mass 0) get neither force nor gravity.
        self._inverse_mass = np.divide(1.0, mass, out=np.zeros_like(mass), where=mass > 0)
        self._free = (mass > 0)[:, None]
        apo = run.aponeurosis
        self._a, self._b = apo.round_vertices, apo.shank_vertices
        self._binding_length = apo.rest_length_m
        self._binding_stiffness = apo.stiffness_n_m
        self._binding_damping = apo.damping_n_s_m
        self._gravity = np.array(run.model.opt.gravity)
        # The shank's bottom vertices stand on the table top at the lowest rest height.
        self._table_z = float(self._rest[:, 2].min())
        self.reset()

    def reset(self) -> None:
        """Back to rest."""
        self.position = self._rest.copy()
        self.velocity = np.zeros_like(self._rest)

    def step(self, count: int, timestep_s: float) -> None:
        """``count`` semi-implicit Euler steps of ``timestep_s`` (s)."""
        n = len(self.position)
        i, j, a, b = self._i, self._j, self._a, self._b
        for _ in range(count):
            x, v = self.position, self.velocity
            d = x[j] - x[i]
            length = np.linalg.norm(d, axis=1)
            u = d / length[:, None]
            rate = np.einsum("ij,ij->i", v[j] - v[i], u)
            tension = self._stiffness * (length - self._length + self._damping_s * rate)
            pull = tension[:, None] * u
            ends = np.concatenate([i, j])
            signed = np.concatenate([pull, -pull])
            force = np.stack([np.bincount(ends, signed[:, k], minlength=n) for k in range(3)],
                             axis=1)
            gap = x[b] - x[a]
            span = np.linalg.norm(gap, axis=1)
            w = gap / span[:, None]
            binding = (self._binding_stiffness * (span - self._binding_length)
                       + self._binding_damping * np.einsum("ij,ij->i", v[b] - v[a], w))
            force[a] += binding[:, None] * w  # round and shank vertices are distinct
            force[b] -= binding[:, None] * w
            v += timestep_s * (force * self._inverse_mass[:, None] + self._gravity * self._free)
            x += timestep_s * v
            below = x[:, 2] < self._table_z
            x[below, 2] = self._table_z
            v[below, 2] = np.maximum(v[below, 2], 0.0)


def stock_flex_run(cell_size_m: float) -> TissueRun:
    """MuJoCo's stock flex peer: the same muscles as ``flexcomp`` with ``<elasticity>``
    (StVK, 0.03 MPa), bound by ``connect`` equalities, on the same table, nothing computed
    outside MuJoCo, MuJoCo's default solver options and the ``discrete`` integrator that
    elasticity needs.

    Example:
        >>> run = stock_flex_run(0.05)
        >>> run.model.opt.solver == mujoco.mjtSolver.mjSOL_NEWTON
        True
    """
    scenario = _scenario(ContinuumMaterial(), cell_size_m, 0.002)
    scenario = replace(scenario, aponeurosis=replace(scenario.aponeurosis, law="constraint"))
    run = TissueRun(scenario, runtime_forces=False)
    default = mujoco.MjModel.from_xml_string("<mujoco/>").opt
    for name in ("solver", "cone", "iterations", "ls_iterations", "tolerance"):
        setattr(run.model.opt, name, getattr(default, name))
    return run


def _cube(cells: int, side_m: float) -> TetMesh:
    axis = np.linspace(0.0, side_m, cells + 1)
    grid = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
    return TetMesh.from_arrays(grid, structured_hex_tets((cells, cells, cells)), "tension cube")


def _stiffest_modulus_pa(material: ContinuumMaterial | MassSpringMaterial) -> float:
    if isinstance(material, ContinuumMaterial):
        return material.young_pa
    return max(material.longitudinal.max_modulus_pa(), material.transverse.max_modulus_pa())


def tension_force_n(material: ContinuumMaterial | MassSpringMaterial, cells: int,
                    side_m: float = 0.1, strain: float = 0.1) -> float:
    """Reaction force (N) of a cube pulled ``strain`` of its height along z, quasi-statically.

    The cube (``cells`` per edge, mirrored Kuhn tets) has its bottom face pinned and its top
    face clamped and moved up, no gravity; mass-spring fibres run along the pull. The top
    vertices get a huge mass (the implicit solver of ``discrete`` then leaves them where they
    are put) and are moved along a ramp; dof damping, critical for the cube's first mode,
    settles the rest (it leaves the static state alone). The force is the elastic force on
    the top face at rest: the springs' share of ``qfrc_applied`` for the mass-spring model,
    ``qfrc_spring`` for MuJoCo's flex elasticity.

    Example:
        >>> round(tension_force_n(ContinuumMaterial(), 2), 1)  # doctest: +SKIP
        53.7
    """
    if isinstance(material, MassSpringMaterial):
        material = replace(material, fibre_direction=(0.0, 0.0, 1.0))
    mesh = _cube(cells, side_m)
    z = mesh.points[:, 2]
    bottom = np.flatnonzero(z < 1e-9 * side_m)
    top = np.flatnonzero(z > side_m * (1.0 - 1e-9))
    flex = flexcomp_xml("cube", mesh.points, mesh.tets, material,
                        material.density_kg_m3 * mesh.volume_m3, radius_m=0.0005,
                        contact='contype="0" conaffinity="0"', pins=bottom.tolist())
    spec = mujoco.MjSpec.from_string(
        f'<mujoco><option gravity="0 0 0"/><worldbody>{flex}</worldbody></mujoco>')
    if isinstance(material, ContinuumMaterial) and material.law == "neo_hookean":
        for f in spec.flexes:
            f.elastic3d = 1  # as build_scene does: the flag has no MJCF attribute
    spec.option.integrator = integrator(Scenario(material=material))
    model = spec.compile()
    springs = (MassSpringModel(model, ("cube",), material)
               if isinstance(material, MassSpringMaterial) else None)
    omega = math.pi * math.sqrt(_stiffest_modulus_pa(material) / material.density_kg_m3) / side_m
    # The continuum runs implicitly (any step); the springs at their stable step.
    model.opt.timestep = 0.2 / omega if springs is None else springs.stable_timestep_s()
    model.dof_damping[:] = 2.0 * omega * model.body_mass[model.dof_bodyid]
    held = np.array([model.body(f"cube_{i}").id for i in top])
    model.body_mass[held] = _HELD_MASS_KG
    data = mujoco.MjData(model)
    mujoco.mj_setConst(model, data)
    qpos = model.jnt_qposadr[model.body_jntadr[held]] + 2
    dofs = model.body_dofadr[held][:, None] + np.arange(3)
    ramp_s, hold_s = 10.0 / omega, 15.0 / omega
    steps = math.ceil((ramp_s + hold_s) / model.opt.timestep)
    for k in range(steps + 1):
        data.qpos[qpos] = strain * side_m * min(1.0, k * model.opt.timestep / ramp_s)
        data.qvel[dofs] = 0.0
        if springs is not None:
            springs.apply(data)
        if k < steps:
            mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    return float(-(data.qfrc_applied + data.qfrc_spring)[dofs[:, 2]].sum())


def extrapolated_force_n(forces: dict[int, float]) -> tuple[float, float | None]:
    """Richardson extrapolation of forces on three meshes (cells per edge -> N) to zero cell
    size, with the convergence order fitted to them; returns the limit and the order.

    Falls back to the finest force (order None) where the three are not in the asymptotic
    range (not monotone, or not shrinking).

    Example:
        >>> f = {n: 40.0 + 12.0 / n for n in (8, 12, 16)}
        >>> [round(v, 6) for v in extrapolated_force_n(f)]
        [40.0, 1.0]
    """
    (na, fa), (nb, fb), (nc, fc) = sorted(forces.items())
    d1, d2 = fa - fb, fb - fc
    if d1 * d2 <= 0.0:
        return fc, None

    def mismatch(order: float) -> float:
        return (na**-order - nb**-order) / (nb**-order - nc**-order) - d1 / d2

    low, high = 0.05, 8.0
    if mismatch(low) * mismatch(high) > 0.0:
        return fc, None
    order = brentq(mismatch, low, high, xtol=1e-12)
    # The finest mesh's own error, c nc**-order, is d2 / ((nc / nb)**order - 1).
    return fc - d2 / ((nc / nb) ** order - 1.0), order


def _cells_per_edge(cell_size_m: float, side_m: float) -> int:
    return max(1, round(side_m / cell_size_m))


def _realism(model: TissueModel, params: TissueBenchParams) -> dict[str, Any]:
    """The tension test's reference for ``model`` and its force at every bench size."""
    sizes = {c: _cells_per_edge(c, params.block_side_m) for c in params.cell_sizes_m}
    forces = {n: tension_force_n(model.material, n, params.block_side_m, params.block_strain)
              for n in sorted({*params.reference_cells, *sizes.values()})}
    fine = sorted(params.reference_cells)
    reference, order = extrapolated_force_n({n: forces[n] for n in fine})
    # Without a fitted order, the last refinement's change bounds the finest mesh's error.
    finest_error = abs(forces[fine[2]] - (reference if order is not None else forces[fine[1]]))
    return {
        "reference_force_n": reference,
        "reference": f"Richardson extrapolation of the same model on {params.reference_cells} "
                     "cells per edge",
        "why": "each model against its own converged limit measures the error of this mesh "
               "alone; a common reference would add each model's own error (a spring "
               "lattice's fixed Poisson ratio, StVK against neo-Hookean), which the reference "
               "forces of the models show instead",
        "convergence_order": order,
        "finest_mesh_error_pct": finest_error / abs(reference) * 100.0,
        "force_n": {str(n): f for n, f in forces.items()},
        "force_error_pct": {
            str(c): abs(forces[n] - reference) / reference * 100.0 for c, n in sizes.items()},
    }


@contextmanager
def _quiet_mujoco() -> Iterator[None]:
    """MuJoCo's warnings dropped: the stable step search diverges on purpose, and the default
    handler would print each and append it to MUJOCO_LOG.TXT. The default comes back after."""
    mujoco.set_mju_user_warning(lambda message: None)
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(None)


def _prepared(run: TissueRun, params: TissueBenchParams) -> tuple[dict[str, Any], TimingJob]:
    """Stable step search of ``run``, then a warm-up at 0.9 times the stable step; returns
    the entry so far and the timing job, which starts from the warmed-up state."""
    formula = run.formula_timestep_s()
    with _quiet_mujoco():
        stable, capped = largest_stable_timestep_s(
            lambda h: run.survives(h, params.stability_steps),
            formula if formula is not None else params.max_timestep_s / 2.0,
            params.max_timestep_s, params.stability_tolerance)
    # The runtime refuses a step above 0.9 times the springs' own stable step.
    timestep = _RUN_SAFETY * min(stable, formula or math.inf)
    run.model.opt.timestep = timestep
    run.reset()
    run.step(params.warmup_steps)
    warm = mujoco.MjData(run.model)
    mujoco.mj_copyData(warm, run.model, run.data)
    steps = _timing_steps(params, run.nodes)
    entry = {"nodes": run.nodes, "stable_timestep_s": stable, "stable_timestep_capped": capped,
             "formula_timestep_s": formula, "run_timestep_s": timestep, "timed_steps": steps}
    return entry, TimingJob(run.step, lambda: run.reset(warm), steps)


def _timed(entry: dict[str, Any], timing: StepTime) -> dict[str, Any]:
    """``entry`` with its timing figures."""
    return {**entry,
            "us_per_node_step": timing.wall_s / entry["nodes"] * 1e6,
            "cpu_us_per_node_step": timing.cpu_s / entry["nodes"] * 1e6,
            "real_time_factor": entry["run_timestep_s"] / timing.wall_s}


def _checked(run: TissueRun, entry: dict[str, Any]) -> dict[str, Any]:
    """``entry`` once the state its timing left is known to be data, with the MuJoCo
    warnings that do not make it wrong (such as an under-converged solve) but still tell."""
    reason = run.divergence()
    if reason is not None:
        raise DivergenceError(float(run.data.time),
                              f"timing run at {entry['run_timestep_s']:.3g} s: {reason}")
    warnings = {mujoco.mjtWarning(i).name: int(stat.number)
                for i, stat in enumerate(run.data.warning) if stat.number > 0}
    return {**entry, "mujoco_warnings": warnings}


def _timing_steps(params: TissueBenchParams, nodes: int) -> int:
    """Steps per timed repetition: about the same wall time per repetition at every size."""
    smallest = 240
    return max(params.min_timing_steps, round(params.timing_steps * smallest / nodes))


def _time_runs(runs: dict[str, TissueRun], params: TissueBenchParams,
               numpy_peer_of: str | None = None) -> dict[str, dict[str, Any]]:
    """Stable step, warm-up and interleaved timing of every run, and of the numpy peer of the
    run ``numpy_peer_of`` (at that run's step) under the key ``numpy_mass_spring``."""
    prepared = {key: _prepared(run, params) for key, run in runs.items()}
    jobs = {key: job for key, (_, job) in prepared.items()}
    entries = {key: entry for key, (entry, _) in prepared.items()}
    peer = None
    if numpy_peer_of is not None:
        peer = NumpyMassSpring(runs[numpy_peer_of])
        timestep = entries[numpy_peer_of]["run_timestep_s"]
        peer.step(params.warmup_steps, timestep)
        steps = _timing_steps(params, runs[numpy_peer_of].nodes)
        entries["numpy_mass_spring"] = {
            "label": "plain numpy mass-spring (semi-implicit Euler, linear springs, clamp "
                     "table)", "nodes": runs[numpy_peer_of].nodes, "run_timestep_s": timestep,
            "timed_steps": steps}
        jobs["numpy_mass_spring"] = TimingJob(lambda n: peer.step(n, timestep), peer.reset,
                                              steps)
    timings = dict(zip(jobs, best_step_times(list(jobs.values()), params.repetitions),
                       strict=True))
    if peer is not None and not np.isfinite(peer.position).all():
        raise DivergenceError(0.0, "the numpy peer diverged")
    return {key: _checked(runs[key], _timed(entry, timings[key])) if key in runs
            else _timed(entry, timings[key]) for key, entry in entries.items()}


def _bench_size(cell_size_m: float, params: TissueBenchParams,
                realism: dict[str, dict[str, Any]]) -> dict[str, Any]:
    models = tissue_models()
    runs = {model.key: TissueRun(_scenario(model.material, cell_size_m, 0.002))
            for model in models}
    runs["mujoco_stock_flex"] = stock_flex_run(cell_size_m)
    meat = "mass_spring_nonlinear_anisotropic"
    entries = _time_runs(runs, params, numpy_peer_of=meat)
    numpy_us = entries["numpy_mass_spring"]["us_per_node_step"]
    for key, entry in entries.items():
        if key != "numpy_mass_spring":
            entry["ratio_to_numpy"] = entry["us_per_node_step"] / numpy_us
    for model in models:
        entries[model.key] |= {"label": model.label, "family": model.family,
                               "force_error_pct":
                               realism[model.key]["force_error_pct"][str(cell_size_m)]}
    entries["mujoco_stock_flex"]["label"] = (
        "MuJoCo stock flex (StVK <elasticity>, connect bindings, defaults)")
    return {"cell_size_m": cell_size_m, "nodes": runs[meat].nodes,
            "models": {model.key: entries[model.key] for model in models},
            "peers": {key: entries[key] for key in ("numpy_mass_spring", "mujoco_stock_flex")}}


def _targets(sizes: list[dict[str, Any]], realtime: dict[str, dict[str, Any]] | None
             ) -> dict[str, dict[str, Any]]:
    """The issue's three targets, each with its value, limit and verdict (None when the run
    did not reach the size it needs: ``--quick``)."""
    key = "mass_spring_nonlinear_anisotropic"
    near = min(sizes, key=lambda size: abs(size["nodes"] - 1000))
    evaluated = abs(near["nodes"] - 1000) <= 200
    us = near["models"][key]["us_per_node_step"] if evaluated else None
    targets = {"us_per_node_step_1000_nodes": {
        "what": "non-linear anisotropic mass-spring, two muscles, bindings, table contact: "
                "us per node per step at about 1000 nodes",
        "nodes": near["nodes"] if evaluated else None, "value": us, "limit": 1.0,
        "pass": None if us is None else us <= 1.0}}
    for name, what in (("real_time_default_meat_2000_nodes", "default meat"),
                       ("real_time_paper_fig10_2000_nodes",
                        "paper Fig. 10: El = 0.25 MPa, Et = Er = 0.6 MPa")):
        entry = None if realtime is None else realtime[name]
        factor = None if entry is None else entry["real_time_factor"]
        targets[name] = {
            "what": f"real-time factor, {what}, about 2000 nodes, one core, own stable step",
            "nodes": None if entry is None else entry["nodes"],
            "timestep_s": None if entry is None else entry["run_timestep_s"],
            "value": factor, "limit": 1.0, "pass": None if factor is None else factor >= 1.0}
    return targets


def run_tissue_bench(params: TissueBenchParams | None = None,
                     progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Run every tissue model and both peers at every size; returns the JSON-ready report
    (module docstring). ``progress`` receives a line per finished part.

    Example:
        >>> report = run_tissue_bench(TissueBenchParams.quick())  # doctest: +SKIP
        >>> sorted(report["sizes"][0]["peers"])  # doctest: +SKIP
        ['mujoco_stock_flex', 'numpy_mass_spring']
    """
    params = TissueBenchParams() if params is None else params
    say = progress or (lambda line: None)
    start = time.perf_counter()
    realism = {}
    for model in tissue_models():
        realism[model.key] = _realism(model, params)
        say(f"tension test {model.key}: reference {realism[model.key]['reference_force_n']:.4g}"
            " N")
    sizes = []
    for cell_size in params.cell_sizes_m:
        sizes.append(_bench_size(cell_size, params, realism))
        say(f"size {cell_size} m ({sizes[-1]['nodes']} nodes) done")
    realtime = None
    if params.realtime_cell_size_m is not None:
        size = params.realtime_cell_size_m
        paper = paper_fig10_material(paper_damping_s(paper_fig10_material(), size))
        materials = {
            "real_time_default_meat_2000_nodes": ("default meat", default_meat()),
            "real_time_paper_fig10_2000_nodes":
                ("paper Fig. 10 (El 0.25, Et 0.6 MPa), paper's D = 0.1 N s/m", paper)}
        realtime = _time_runs({name: TissueRun(_scenario(material, size, 0.002))
                               for name, (_, material) in materials.items()}, params)
        for name, (label, material) in materials.items():
            realtime[name] |= {"label": label, "damping_s": material.damping_s}
            say(f"{name}: {realtime[name]['real_time_factor']:.3g}x real time")
    return {
        "suite": "tissue",
        "machine": {"python": platform.python_version(), "processor": platform.machine(),
                    "mujoco": mujoco.__version__, "cpus": cpu_count(),
                    "threads_per_step": 1, "load_average": list(os.getloadavg())},
        "settings": asdict(params),
        "paper_table_1": {
            "measured_here": False,
            "note": "Nabil et al. 2015, Table 1, Core 2 Duo 3 GHz: per node per iteration; "
                    "quoted for comparison, not measured here",
            "us_per_node_iteration": PAPER_TABLE_1_US},
        "realism": realism,
        "sizes": sizes,
        "real_time": realtime,
        "targets": _targets(sizes, realtime),
        "wall_time_s": time.perf_counter() - start,
    }


def _number(value: float | None, digits: int = 3) -> str:
    return "-" if value is None else f"{value:.{digits}g}"


def markdown_report(report: dict[str, Any]) -> str:
    """The report of :func:`run_tissue_bench` as Markdown tables.

    Example:
        >>> print(markdown_report(report))  # doctest: +SKIP
    """
    lines = [
        "# musclecell bench tissue",
        "",
        "Two bound muscles on the table, no robots; one thread. Stable step: largest step a "
        f"{report['settings']['stability_steps']}-step run from rest survives (capped at "
        f"{report['settings']['max_timestep_s'] * 1e3:g} ms, marked >=); formula: "
        "`MassSpringModel.stable_timestep_s(safety=1)`. Runs at 0.9 times the smaller. "
        "cpu: this process's CPU time (other processes do not inflate it; the wall figure is "
        "the one reported). "
        "x numpy: us/node/step over the plain numpy mass-spring peer's, same run, same mesh. "
        "Force error: tension test (cube, bottom pinned, top pulled 10%) at the same cell "
        "size, against the same model extrapolated from fine meshes.",
        "",
        "| model | nodes | us/node/step | cpu us/node/step | x numpy | stable dt (ms) "
        "| formula dt (ms) | run dt (ms) | real-time factor | force error (%) |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for size in report["sizes"]:
        rows = [*size["models"].values(), *size["peers"].values()]
        for row in rows:
            stable = row.get("stable_timestep_s")
            capped = ">=" if row.get("stable_timestep_capped") else ""
            formula = row.get("formula_timestep_s")
            lines.append(
                f"| {row['label']} | {row['nodes']} | {row['us_per_node_step']:.3g} "
                f"| {row['cpu_us_per_node_step']:.3g} | {_number(row.get('ratio_to_numpy'))} "
                f"| {capped}{_number(None if stable is None else stable * 1e3)} "
                f"| {_number(None if formula is None else formula * 1e3)} "
                f"| {row['run_timestep_s'] * 1e3:.3g} | {row['real_time_factor']:.3g} "
                f"| {_number(row.get('force_error_pct'))} |")
    lines += ["", "## Tension test references", "",
              "| model | reference force (N) | order | finest mesh error (%) |",
              "| --- | ---: | ---: | ---: |"]
    for key, entry in report["realism"].items():
        lines.append(f"| {key} | {entry['reference_force_n']:.4g} "
                     f"| {_number(entry['convergence_order'])} "
                     f"| {entry['finest_mesh_error_pct']:.2g} |")
    if report["real_time"]:
        lines += ["", "## About 2000 nodes, non-linear / linear anisotropic mass-spring", "",
                  "| material | nodes | damping (s) | stable dt (ms) | formula dt (ms) "
                  "| run dt (ms) | us/node/step | cpu us/node/step | real-time factor |",
                  "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
        for entry in report["real_time"].values():
            lines.append(f"| {entry['label']} | {entry['nodes']} | {entry['damping_s']:.2g} "
                         f"| {entry['stable_timestep_s'] * 1e3:.3g} "
                         f"| {entry['formula_timestep_s'] * 1e3:.3g} "
                         f"| {entry['run_timestep_s'] * 1e3:.3g} "
                         f"| {entry['us_per_node_step']:.3g} "
                         f"| {entry['cpu_us_per_node_step']:.3g} "
                         f"| {entry['real_time_factor']:.3g} |")
    lines += ["", "## Targets", "", "| target | value | limit | pass |",
              "| --- | ---: | ---: | --- |"]
    for name, target in report["targets"].items():
        verdict = "not run" if target["pass"] is None else str(target["pass"]).lower()
        lines.append(f"| {name} ({target['what']}) | {_number(target['value'])} "
                     f"| {target['limit']:g} | {verdict} |")
    paper = report["paper_table_1"]
    lines += ["", "## Paper, Table 1 (NOT measured here)", "", paper["note"] + ".", "",
              "| code | us per node per iteration |", "| --- | ---: |"]
    lines += [f"| {name} | {value:g} |" for name, value in paper["us_per_node_iteration"].items()]
    return "\n".join(lines) + "\n"
