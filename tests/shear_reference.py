"""The meshed reference of the shear and biaxial solves: the same springs on every vertex of a
tet mesh of the specimen in MuJoCo, in time, as :mod:`tests.specimen_reference` runs the
uniaxial tests (its mass scaling, damping and flex).

The faces follow the displacement gradient ``H = F - I`` of the test by having their vertices'
slide ``qpos`` and ``qvel`` written before every step, each face only along the components the
homogeneous solve prescribes:

- simple shear: every face follows ``u = H X`` whole (the homogeneous simple shear that
  :mod:`cell.diagnosis.specimen.shearbiaxial` solves; ``lateral_free`` leaves the lateral faces
  free instead, as a glued specimen between two plates is);
- biaxial: the z faces follow along z and the x faces along x (lubricated: they slide
  freely otherwise), the y faces are free.

The result is the material's force on the top face (z = height) and on the far x face, each
along x and z, at the test's sample times (positive along the axes).

Example:
    >>> from cell.tissue.material import MassSpringMaterial
    >>> t = np.linspace(0.0, 1.0, 5)
    >>> path = np.zeros((5, 4)); path[:, 3] = 0.02 * t
    >>> run = simulate_gradient(CUBE_EXAMPLE, MassSpringMaterial.isotropic(1e4), (0, 0, 1), t,
    ...                         path, shear=True, params=SpecimenSimParams(cells=2))
    >>> run.top_N.shape
    (5, 2)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from cell.diagnosis.specimen.solve import specimen_mesh
from cell.errors import DivergenceError
from cell.measure.specimens import Specimen
from cell.tissue.massspring import MassSpringModel
from cell.tissue.material import MassSpringMaterial
from tests.specimen_reference import (
    SpecimenSimParams,
    inertia_mass_scale,
    softest_modulus_pa,
    specimen_model,
)

CUBE_EXAMPLE = Specimen("cube", (0.01, 0.01, 0.01))
_FLEX = "specimen"


@dataclass(frozen=True, eq=False)
class GradientRun:
    """The meshed forces of one test (module docstring).

    Attributes:
        time_s: (n,) the sample times, s.
        top_N: (n, 2) the material's force on the top face along x and z, N.
        side_N: (n, 2) the material's force on the far x face along x and z, N.
        mass_scale: simulated specimen mass over its real mass.
        steps: number of steps taken.
    """

    time_s: np.ndarray
    top_N: np.ndarray
    side_N: np.ndarray
    mass_scale: float
    steps: int


def _driven(points: np.ndarray, shear: bool, lateral_free: bool) -> np.ndarray:
    """(N, 3) which of each vertex's dofs follow ``u = H X`` (module docstring)."""
    low, high = points.min(axis=0), points.max(axis=0)
    on = [(points[:, k] == low[k]) | (points[:, k] == high[k]) for k in range(3)]
    driven = np.zeros(points.shape, dtype=bool)
    if shear:
        faces = on[2] if lateral_free else on[0] | on[1] | on[2]
        driven[faces] = True
    else:
        driven[:, 0], driven[:, 2] = on[0], on[2]
    return driven


def simulate_gradient(specimen: Specimen, material: MassSpringMaterial,
                      fibre: Sequence[float], time_s: np.ndarray, path: np.ndarray,
                      shear: bool, params: SpecimenSimParams | None = None,
                      lateral_free: bool = False) -> GradientRun:
    """Run the displacement gradients ``path`` ((n, 4): H's xx, yy, zz, xz at ``time_s``) on
    the meshed ``specimen`` of ``material`` with its fibres along ``fibre``, calibrated like
    the homogeneous lattice (fibres along z); ``shear`` picks the faces' drive (module
    docstring).

    Raises:
        DivergenceError: the simulation blew up.
    """
    params = SpecimenSimParams() if params is None else params
    mesh = specimen_mesh(specimen, params.cells)
    time = time_s - time_s[0]
    height = specimen.size_m[2]
    # The test's largest strain component sets the inertia budget, as the uniaxial one does.
    lead = int(np.argmax(np.ptp(path, axis=0)))
    modulus = softest_modulus_pa(material, path[:, lead])
    scale = inertia_mass_scale(time, path[:, lead], height, modulus, specimen.density_kg_m3,
                               params)
    model = specimen_model(mesh, material, specimen.density_kg_m3 * scale * mesh.volume_m3)
    data = mujoco.MjData(model)
    bodies = model.flex_vertbodyid[model.flex_vertadr[0]:][: len(mesh.points)]
    vertex = np.where(model.body_dofnum[bodies] > 0, model.body_dofadr[bodies], -1)
    driven = _driven(mesh.points, shear, lateral_free) & (vertex >= 0)[:, None]
    dof = vertex[:, None] + np.arange(3)
    free = dof[(vertex >= 0)[:, None] & ~driven]
    springs = MassSpringModel(model, (_FLEX,), replace(material, fibre_direction=tuple(fibre)),
                              calibrate_along=(0.0, 0.0, 1.0))
    timestep = params.timestep_safety * springs.stable_timestep_s(safety=1.0)
    model.opt.timestep = timestep
    omega = math.pi / height * math.sqrt(modulus / (specimen.density_kg_m3 * scale))
    model.dof_damping[free] = 2.0 * params.damping_ratio * omega * model.body_mass[
        bodies[np.nonzero((vertex >= 0)[:, None] & ~driven)[0]]]

    steps = math.ceil(float(time[-1]) / timestep) + 1
    grid = np.arange(steps + 1) * timestep
    gradient = np.stack([np.interp(grid, time, path[:, k]) for k in range(4)], axis=1)
    x, y, z = mesh.points.T
    # u = H X for H = [[h_xx, 0, h_xz], [0, h_yy, 0], [0, 0, h_zz]], at every grid time.
    motion = np.stack([np.outer(gradient[:, 0], x) + np.outer(gradient[:, 3], z),
                       np.outer(gradient[:, 1], y), np.outer(gradient[:, 2], z)], axis=2)
    speed = np.diff(motion, axis=0) / timestep
    top, side = driven & (z == z.max())[:, None], driven & (x == x.max())[:, None]
    forces = np.empty((steps, 2, 2))
    for k in range(steps):
        data.qpos[dof[driven]] = motion[k][driven]
        data.qvel[dof[driven]] = speed[k][driven]
        springs.apply(data)
        mujoco.mj_step(model, data)
        for f, face in enumerate((top, side)):
            for c, axis in enumerate((0, 2)):
                mask = face & (np.arange(3) == axis)[None, :]
                forces[k, f, c] = -data.qfrc_applied[dof[mask]].sum()
    if not np.isfinite(forces).all() or data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number:
        raise DivergenceError(float(grid[-1]), "the meshed specimen's state is not finite")
    sampled = np.stack([[np.interp(time, grid[:-1], forces[:, f, c]) for c in range(2)]
                        for f in range(2)])
    return GradientRun(time_s, sampled[0].T, sampled[1].T, scale, steps)
