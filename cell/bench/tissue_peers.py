"""The tissue bench's peers: a plain numpy mass-spring integrator (the MATLAB-style peer) and
MuJoCo's stock flex."""

from __future__ import annotations

from dataclasses import replace

import mujoco
import numpy as np

from cell.bench.tissue_variants import bench_scenario, tissue_run
from cell.errors import ScenarioError
from cell.sim.simulation import TissueSimulation
from cell.tissue.aponeurosis import BindingLaw
from cell.tissue.material import ContinuumMaterial


class NumpyMassSpring:
    """The MATLAB-style peer: the same springs, bindings and masses, integrated with plain
    vectorised numpy (semi-implicit Euler), no MuJoCo.

    Linear spring-dampers with :class:`MassSpringModel`'s edges, rest lengths and small-strain
    stiffnesses and its damping time; the binding springs of the aponeurosis; gravity; the
    table as a clamp (a vertex below it is put back on it and loses its downward speed).
    Pinned vertices stay put.

    Example:
        >>> from cell.bench.tissue_variants import bench_scenario, tissue_run
        >>> from cell.tissue.material import MassSpringMaterial
        >>> peer = NumpyMassSpring(tissue_run(bench_scenario(MassSpringMaterial(), 0.05)))
        >>> peer.step(10, 0.002)
        >>> bool(np.isfinite(peer.position).all())
        True
    """

    def __init__(self, run: TissueSimulation) -> None:
        apo = run.scene.aponeurosis
        if not run.springs or apo.law is not BindingLaw.SPRING:
            raise ScenarioError(None, "material",
                                "the peer copies a mass-spring run with binding springs")
        data = mujoco.MjData(run.model)
        mujoco.mj_kinematics(run.model, data)
        mujoco.mj_flex(run.model, data)
        rest, edges, lengths, stiffness, mass = [], [], [], [], []
        offset = 0
        for muscle, springs in run.springs.items():
            flex = mujoco.mj_name2id(run.model, mujoco.mjtObj.mjOBJ_FLEX, muscle)
            first, count = int(run.model.flex_vertadr[flex]), int(run.model.flex_vertnum[flex])
            # Bindings name global flex vertices: the peer's vertices must be in that order.
            if first != offset:
                raise ScenarioError(None, "tissue",
                                    "the muscles' flex vertices are not round then shank")
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
        self._damping_s = run.springs["round"].material.damping_s
        mass = np.concatenate(mass)
        # Pinned vertices (mass 0) get neither force nor gravity.
        self._inverse_mass = np.divide(1.0, mass, out=np.zeros_like(mass), where=mass > 0)
        self._free = (mass > 0)[:, None]
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


def stock_flex_run(cell_size_m: float) -> TissueSimulation:
    """MuJoCo's stock flex peer: the same muscles as ``flexcomp`` with ``<elasticity>``
    (StVK, 0.03 MPa), bound by ``connect`` equalities, on the same table, nothing computed
    outside MuJoCo, MuJoCo's default solver options and the ``discrete`` integrator that
    elasticity needs. The runtime's forces are nothing here: the tissue dofs' applied forces
    stay zero and the bindings are constraints.

    Example:
        >>> run = stock_flex_run(0.05)
        >>> run.model.opt.solver == mujoco.mjtSolver.mjSOL_NEWTON
        True
    """
    scenario = bench_scenario(ContinuumMaterial(), cell_size_m)
    # Constraints carry no force in N for the force rule: release by position and tearing.
    scenario = replace(scenario, aponeurosis=replace(
        scenario.aponeurosis, law="constraint", release_rules=("knife", "tearing")))
    run = tissue_run(scenario)
    default = mujoco.MjModel.from_xml_string("<mujoco/>").opt
    for name in ("solver", "cone", "iterations", "ls_iterations", "tolerance"):
        setattr(run.model.opt, name, getattr(default, name))
    return run

