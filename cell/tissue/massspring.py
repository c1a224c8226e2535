"""The paper's anisotropic non-linear mass-spring model, acting on MuJoCo flex vertices.

Every edge of the tetrahedral mesh is a spring-damper (Eq. 6): the force on its ends is
``-(K (l - l0) + K tau dl/dt)`` along the edge, where l0 is the rest length and ``tau`` the
material's damping time. The stiffness is Eq. 10, ``K = ||E u|| sum(V) / l0**2``: u the edge's
unit rest direction, sum(V) the volume of the tets sharing the edge and E = diag(El, Et, Er)
the modulus matrix in the fibre frame (Et = Er), so that ``||E u|| = sqrt(El**2 c**2 +
Et**2 (1 - c**2))`` with c the cosine between the edge and the fibres; with El = Et = E it is
Eq. 8, ``K = E sum(V) / l0**2``. Both moduli are updated every step from the spring's stretch
r = l / l0 (:class:`~cell.tissue.curves.ModulusCurve`); K uses their secant values
``sigma(r) / (r - 1)``, so that a spring's force follows the measured stress curve
(a conservative spring) instead of the tangent modulus times the extension. Under the
implicit step the law runs once every ``law_refresh_steps`` steps (the cell passes its steps per
control step: once per control step), with its derivative for the step's matrix; in between
each spring's tension follows the law's tangent line from that run, along the spring's present
direction.

Calibration: the moduli fed to Eq. 10 are those for which the lattice of the muscle's own
mesh has the material's moduli (:mod:`cell.tissue.lattice`).

Forces go into ``data.qfrc_applied`` at the vertex dofs (3 slide joints per vertex body); the
kernel is compiled with numba. Positions are the vertex bodies' rest positions plus their slide
``qpos``, in the frame of the flex's parent body, which must be static (the world or a body
welded to it): the current state, with no kinematics pass and no lag.

Example:
    >>> import mujoco
    >>> from cell.tissue.flexcomp import flexcomp_xml
    >>> from cell.tissue.material import MassSpringMaterial
    >>> from cell.tissue.tetmesh import structured_hex_tets
    >>> material = MassSpringMaterial()
    >>> corners = 0.02 * np.stack(np.meshgrid(*[[0.0, 1.0]] * 3, indexing="ij"), -1)
    >>> flex = flexcomp_xml("cube", corners.reshape(-1, 3), structured_hex_tets((1, 1, 1)),
    ...                     material, 1e-2, radius_m=1e-4, pins=[0, 2, 4, 6])
    >>> model = mujoco.MjModel.from_xml_string(f"<mujoco><worldbody>{flex}</worldbody></mujoco>")
    >>> data = mujoco.MjData(model)
    >>> springs = MassSpringModel(model, ("cube",), material)
    >>> springs.apply(data)  # before every step
    >>> mujoco.mj_step(model, data)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import mujoco
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl

from cell.errors import InputError, MeshError
from cell.tissue.implicit import ImplicitSystem
from cell.tissue.lattice import (
    AffineLattice,
    calibrated_law,
    directional_modulus,
    oblique_gain,
    sheet_gain,
    tet_edges,
)
from cell.tissue.material import MassSpringMaterial
from cell.tissue.springlaw import TANGENT_COLUMNS, muscle_forces


class MassSpringModel:
    """Anisotropic non-linear springs on the edges of MuJoCo 3D flexes (module docstring).

    The flexes must have no elasticity of their own (no ``<elasticity>``, or ``young="0"``),
    and vertex bodies with three slide joints along their parent's axes (flexcomp's default);
    the model's edge damping of the flexes is set to zero (the springs' dashpots replace it);
    pinned vertices have no dofs and stay where their parent puts them. :meth:`apply` owns the
    vertex dofs' entries of ``data.qfrc_applied``: it clears and rewrites them at every call
    and leaves every other entry alone; put external loads on vertices in ``xfrc_applied``.
    All flexes share one material and one fibre direction; use one model per muscle to give
    each muscle its own. A material with history (plasticity, relaxation) advances it by the
    model's time step at every :meth:`apply` (an implicit model's law runs at every
    ``law_refresh_steps``-th and advances it by that many steps): call it once per step, and
    :meth:`reset` with ``mj_resetData``.

    ``law_refresh_steps``: under the implicit step, the steps from one run of the spring law
    to the next (the cell's physics steps per control step,
    :attr:`~cell.sim.scenario.SimulationParams.control_substeps`); 1, the default, runs it at
    every step. The explicit step runs it at every step. Refreshing the law, its tangent
    stiffness and the solve's preconditioner once per control step saves most of the law's
    cost, and over one control step a spring's length changes too little for the tangent line
    to part from the curve (``tests/tissue/test_massspring.py``, the bench's accuracy tests).

    Attributes:
        material: the material, its fibre direction the one now in use.
        edges: (E, 2) vertex pairs, indices into the flexes' vertices taken in order.
        rest_lengths_m: (E,) rest length of each spring, m.
        edge_volume_m3: (E,) volume of the tets sharing each spring, m^3.
        fibre_cosine: (E,) cosine between each spring's rest direction and the fibres.
        calibration: (alpha, beta), the factors on El and Et fed to Eq. 10.
        sheet_factor: k of the springs' sheet gain ``1 + (k - 1) (u . s)**2`` (the material's
            orthotropy on this lattice, :func:`~cell.tissue.lattice.sheet_factor`; 1 for a
            transversely isotropic material).
        calibrate_along: the direction the lattice is calibrated in; None for the fibres'.
        stiffness_n_m: (E,) calibrated small-strain stiffness of each spring, N/m.
        dofadr: (N,) first dof of each vertex's slide joints, -1 for pinned vertices.
        vertex_mass_kg: (N,) mass of each vertex body, kg (0 for pinned vertices).

    Example:
        >>> import mujoco
        >>> from cell.tissue.flexcomp import flexcomp_xml
        >>> from cell.tissue.tetmesh import structured_hex_tets
        >>> material = MassSpringMaterial.transversely_isotropic(0.25e6, 0.6e6)
        >>> grid = 0.01 * np.stack(np.meshgrid(*[[0.0, 1.0, 2.0]] * 3, indexing="ij"), -1)
        >>> flex = flexcomp_xml("block", grid.reshape(-1, 3), structured_hex_tets((2, 2, 2)),
        ...                     material, 1e-2, radius_m=1e-4)
        >>> model = mujoco.MjModel.from_xml_string(
        ...     f"<mujoco><worldbody>{flex}</worldbody></mujoco>")
        >>> springs = MassSpringModel(model, ("block",), material)
        >>> model.opt.timestep = springs.stable_timestep_s()
        >>> springs.set_fibre_direction((0.0, 1.0, 0.0))  # the vision module's update
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        flexes: Sequence[str],
        material: MassSpringMaterial,
        calibrate_along: Sequence[float] | None = None,
        implicit: bool = False,
        law_refresh_steps: int = 1,
    ) -> None:
        if law_refresh_steps < 1:
            raise InputError(None, "law_refresh_steps",
                             f"must be >= 1, got {law_refresh_steps}")
        self._model = model
        self.law_refresh_steps = law_refresh_steps
        self.calibrate_along = calibrate_along
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        mujoco.mj_flex(model, data)
        points, tets, vertices, bodies = [], [], [], []
        count = 0
        for name in flexes:
            flex = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_FLEX, name)
            if flex < 0 or model.flex_dim[flex] != 3:
                raise MeshError(None, f"flex {name}", "no 3D (tetrahedral) flex of that name")
            # The springs' dashpots replace the flex's own edge damping, whose vanishing
            # value only marks the flex as soft at compile time (flexcomp_xml); computing it
            # took a large share of mj_step on the muscles.
            model.flex_edgedamping[flex] = 0.0
            first, n = int(model.flex_vertadr[flex]), int(model.flex_vertnum[flex])
            world = data.flexvert_xpos[first : first + n].copy()
            bodies.append(model.flex_vertbodyid[first : first + n])
            vertices.append(_flex_vertices(model, data, name, bodies[-1], world))
            elem = int(model.flex_elemdataadr[flex])
            local = model.flex_elem[elem : elem + 4 * int(model.flex_elemnum[flex])]
            points.append(world)
            tets.append(local.reshape(-1, 4) + count)
            count += n
        qposadr, dofadr, rest, mass = (
            np.concatenate(column) for column in zip(*vertices, strict=True)
        )
        self._points = np.concatenate(points)
        self.edges, self.edge_volume_m3 = tet_edges(self._points, np.concatenate(tets))
        d = self._points[self.edges[:, 1]] - self._points[self.edges[:, 0]]
        self.rest_lengths_m = np.linalg.norm(d, axis=1)
        self._gain = self.edge_volume_m3 / self.rest_lengths_m**2
        self._qposadr = qposadr
        self.dofadr = dofadr
        self._rest_position = rest
        self.vertex_mass_kg = mass
        self._position = np.zeros_like(self._rest_position)
        self._velocity = np.zeros_like(self._rest_position)
        free = dofadr >= 0
        armature = np.where(free, model.dof_armature[np.maximum(dofadr, 0)], 0.0)
        bodies = np.concatenate(bodies)
        self.implicit = (ImplicitSystem(self.edges, mass + armature, dofadr, bodies, mass)
                         if implicit else None)
        self._tangent = np.zeros((len(self.edges) if implicit else 0, TANGENT_COLUMNS))
        self._steps = 0
        self.material = material
        self.set_fibre_direction(material.fibre_direction)

    @property
    def vertex_count(self) -> int:
        """Number of vertices of all the flexes, pinned ones included."""
        return len(self.dofadr)

    @property
    def runs_law(self) -> bool:
        """Whether the next :meth:`apply` runs the spring law: at every step for the explicit
        step, at every ``law_refresh_steps``-th for the implicit one (each spring follows the
        law's tangent line in between)."""
        return self._steps % self.law_refresh_steps == 0

    @property
    def history_columns(self) -> int:
        """Numbers the spring law keeps per spring (plastic strain, relaxing stress and one
        per relaxation term: :mod:`cell.tissue.springlaw`)."""
        return int(self._history.shape[1])

    def vertex_state(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """(N, 3) the vertices' positions (m, in the flexes' parent frame) and velocities
        (m/s) in ``data``; pinned vertices at rest."""
        free = self._qposadr >= 0
        position = self._rest_position.copy()
        velocity = np.zeros_like(position)
        position[free] += data.qpos[self._qposadr[free, None] + np.arange(3)]
        velocity[free] = data.qvel[self.dofadr[free, None] + np.arange(3)]
        return position, velocity

    def set_fibre_direction(self, direction: np.ndarray | Sequence[float]) -> None:
        """Turn the fibres to ``direction`` (world frame, any length) and recalibrate.

        The springs keep their history.

        Raises:
            MaterialError: ``fibre_direction`` zero, or ``longitudinal`` when the lattice cannot
                give the material's anisotropy in that direction.
        """
        material = replace(self.material, fibre_direction=tuple(float(v) for v in direction))
        fibre = np.asarray(material.fibre_direction)
        along = fibre if self.calibrate_along is None else self.calibrate_along
        self._law, self.calibration, self._compression_calibration, self.sheet_factor = (
            calibrated_law(self._points, self.edges, self.edge_volume_m3, material, along))
        self.material = material
        sheet = np.asarray(material.sheet_direction) if material.orthotropic else None
        lattice = AffineLattice(self._points, self.edges, self.edge_volume_m3, fibre,
                                sheet=sheet)
        self._cos_sq = lattice.cos_sq
        # Each spring's K l**2 over its modulus, the sheets' gain included.
        self._spring_gain = (self._gain if self.sheet_factor == 1.0
                             else self._gain * sheet_gain(self.sheet_factor, lattice.sheet_sq))
        self.fibre_cosine = np.sqrt(self._cos_sq)
        if not hasattr(self, "_history"):
            self._history = self._law.history(len(self.edges))
        self.stiffness_n_m = self._stiffness(
            self.calibration[0] * material.longitudinal.small_strain_modulus_pa,
            self.calibration[1] * material.transverse.small_strain_modulus_pa)

    def reset(self) -> None:
        """Put every spring back at rest: no plastic strain, nothing left to relax."""
        self._history[:] = 0.0
        self._steps = 0
        if self.implicit is not None:
            self.implicit.reset()

    def _stiffness(self, el_pa: float, et_pa: float) -> np.ndarray:
        return (self._spring_gain * directional_modulus(el_pa, et_pa, self._cos_sq)
                * oblique_gain(self.material.oblique, self._cos_sq))

    def apply(self, data: mujoco.MjData, filtered: bool = True) -> None:
        """Write the springs' forces for the state in ``data`` into ``data.qfrc_applied``;
        an implicit model then filters them (:meth:`filter`) unless ``filtered`` is False
        (the caller adds forces of its own and filters after)."""
        refresh = self.runs_law
        # The law moves the history on by the time since it last ran.
        elapsed = 1 if self._steps == 0 else self.law_refresh_steps
        muscle_forces(
            data.qpos,
            data.qvel,
            data.qfrc_applied,
            self._qposadr,
            self.dofadr,
            self._rest_position,
            self.edges,
            self.rest_lengths_m,
            self._spring_gain,
            self._cos_sq,
            self._law.curves,
            self._law.params,
            self._history,
            self._model.opt.timestep * elapsed,
            self.material.damping_s,
            self._position,
            self._velocity,
            self._tangent,
            refresh,
        )
        if filtered:
            self.filter(data)

    def filter(self, data: mujoco.MjData) -> None:
        """Turn the vertices' forces in ``data.qfrc_applied`` into the implicit update's
        (:mod:`cell.tissue.implicit`), after :meth:`apply` at the same state; nothing for an
        explicit model."""
        if self.implicit is not None:
            self.implicit.filter(data.qvel, data.qfrc_applied, self._tangent,
                                 self._model.opt.timestep, self._model.opt.gravity,
                                 data.xfrc_applied, refresh=self.runs_law)
            self._steps += 1

    def stable_timestep_s(self, safety: float = 0.9) -> float:
        """Largest time step the springs allow, s, times ``safety``.

        MuJoCo integrates ``qfrc_applied`` explicitly, so the step is bounded by the highest
        angular frequency w of the springs at rest with the curves' stiffest moduli (the largest
        eigenvalue of M^-1 K); with the dashpots (``K tau``) semi-implicit Euler is stable for
        ``h**2 w**2 + 2 h tau w**2 < 4``. Contacts and bindings go through MuJoCo's constraint
        solver and do not enter. On the two muscles, at several meshes and moduli, the limit
        found by running lies close to the value with ``safety=1`` (docs/benchmarks.md).
        """
        # The packed curves hold the calibrated moduli; their stiffest, in tension or in
        # compression, sets the step. The compensation k stiffens a shortened spring: its
        # tangent gains 1 / (1 + k x)**2.
        squeezed = self.material.in_compression()
        shortest = min(squeezed.longitudinal.r_min, squeezed.transverse.r_min) - 1.0
        gain = (1.0 + self.material.geometric_compensation * shortest) ** -2
        pairs = ((self.material, self.calibration), (squeezed, self._compression_calibration))
        el = gain * max(f[0] * m.longitudinal.max_modulus_pa() for m, f in pairs)
        et = gain * max(f[1] * m.transverse.max_modulus_pa() for m, f in pairs)
        stiffness = self._stiffness(el, et)
        free = self.dofadr >= 0
        # Row of each free vertex's x dof in the reduced system; -1 for pinned vertices.
        row = np.where(free, 3 * np.cumsum(free) - 3, -1)
        direction = (self._points[self.edges[:, 1]] - self._points[self.edges[:, 0]]) / (
            self.rest_lengths_m[:, None]
        )
        block = stiffness[:, None, None] * direction[:, :, None] * direction[:, None, :]
        rows, cols, values = [], [], []
        for a, b, sign in ((0, 0, 1.0), (1, 1, 1.0), (0, 1, -1.0), (1, 0, -1.0)):
            ra, rb = row[self.edges[:, a]], row[self.edges[:, b]]
            both = (ra >= 0) & (rb >= 0)
            k = np.arange(3)
            rows.append((ra[both, None, None] + k[:, None]).repeat(3, axis=2).ravel())
            cols.append((rb[both, None, None] + k[None, :]).repeat(3, axis=1).ravel())
            values.append(sign * block[both].ravel())
        size = 3 * int(free.sum())
        scale = np.repeat(self.vertex_mass_kg[free] ** -0.5, 3)
        matrix = sp.csr_matrix(
            (np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))),
            shape=(size, size),
        )
        reduced = sp.diags(scale) @ matrix @ sp.diags(scale)
        omega_sq = float(spl.eigsh(reduced, k=1, which="LA", return_eigenvectors=False)[0])
        tau = self.material.damping_s
        return safety * (math.sqrt(tau**2 + 4.0 / omega_sq) - tau)


def _flex_vertices(
    model: mujoco.MjModel, data: mujoco.MjData, name: str, bodies: np.ndarray, world: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """qpos and dof addresses (-1 when pinned), rest positions in the parent frame and masses
    of the vertices of flex ``name``, whose vertex bodies are ``bodies``."""
    free = model.body_dofnum[bodies] > 0
    parents = np.unique(np.concatenate([model.body_parentid[bodies[free]], bodies[~free]]))
    if len(parents) != 1:
        raise MeshError(None, f"flex {name}",
                        f"vertices hang from several bodies {parents.tolist()}")
    parent = int(parents[0])
    if model.body_weldid[parent] != 0 or model.body_mocapid[parent] >= 0:
        raise MeshError(None, f"flex {name}", f"parent body {parent} moves; it must be static")
    for body in bodies[free]:
        joints = slice(model.body_jntadr[body], model.body_jntadr[body] + model.body_jntnum[body])
        if (
            model.body_dofnum[body] != 3
            or (model.jnt_type[joints] != mujoco.mjtJoint.mjJNT_SLIDE).any()
            or not np.array_equal(model.jnt_axis[joints], np.eye(3))
            or not np.array_equal(model.body_quat[body], [1.0, 0.0, 0.0, 0.0])
        ):
            raise MeshError(None, f"flex {name}", f"body {body} lacks slide joints along x, y, z")
    rotation = data.xmat[parent].reshape(3, 3)
    rest = (world - data.xpos[parent]) @ rotation
    qposadr = np.full(len(bodies), -1, dtype=np.int64)
    dofadr = np.full(len(bodies), -1, dtype=np.int64)
    qposadr[free] = model.jnt_qposadr[model.body_jntadr[bodies[free]]]
    dofadr[free] = model.body_dofadr[bodies[free]]
    # Slide joints add qpos to the body's rest position: keep the part qpos0 does not hold.
    rest[free] -= model.qpos0[qposadr[free][:, None] + np.arange(3)]
    mass = np.where(free, model.body_mass[bodies], 0.0)
    return qposadr, dofadr, rest, mass
