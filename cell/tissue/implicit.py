"""A linearly implicit step for the springs, handed to MuJoCo as a filtered force.

MuJoCo integrates ``qfrc_applied`` explicitly, so a stiff spring lattice would bound its step
by the springs' highest frequency (:meth:`MassSpringModel.stable_timestep_s`). Instead, every
step solves for the tissue vertices' velocity change dv over the step h with the spring force
taken at a position and velocity ahead of the present ones, linearised::

    M dv = h f(x + h (theta v + beta dv), v + gamma dv)
    (M - gamma h D - beta h**2 K) dv = h (f + theta h K v)

f: the forces on the vertices at the present state (springs and dashpots, binding springs);
K: the springs' stiffness, the force's derivative in position (per spring the tangent
``dT/dl d d^T`` of the spring law over the step, plus the geometric ``T / l (I - d d^T)``
where the spring is in tension, so that the matrix stays positive definite); D: the dashpots;
M: the vertices' masses. The force written for MuJoCo is ``M dv / h``: MuJoCo's own step
(contacts, equalities and the grasp acting on the same step, ``x += h (v + dv)``) then moves
the tissue by the implicit update, plus the constraint forces' share.

The forces MuJoCo adds itself and that are known before the step (gravity,
``xfrc_applied``) enter f as well and are taken off the force written, ``M dv / h - e``:
otherwise the implicit update would hold the springs against a force it does not see, and
move each vertex by ``beta h**2 e / m`` against its neighbours at rest. The constraint forces
(contacts, bindings as equalities, the grasp) are not known before the step and stay out: a
vertex resting on the table sits about ``beta h**2 g`` off, a grasped vertex about
``beta h**2 F / m`` under the grasp's force F. Fed back from the last step, even averaged over
many steps, they took turns with the vertices they push and pumped energy into a stiff meat
(docs/design-notes.md).

With MuJoCo's position update, ``theta = 0, beta = 1/4, gamma = 1/2`` is Newmark's average
acceleration (the trapezoidal rule): unconditionally stable for linear springs, second order,
no numerical damping; ``theta = beta = gamma = 1`` is backward Euler, whose damping
(``h omega / 2`` of critical) eats a free vibration within seconds at a coarse step.
The step keeps a little dissipation ``a`` (``theta = a``, ``gamma = 1/2 + a``,
``beta = (1 + a)**2 / 4``), as Newmark's gamma > 1/2 does, for the undamped trapezoidal rule
let the explicit binding springs pump energy into the muscles at a coarse step. A mode's
numerical damping ratio is then about ``a h omega / 2``: at the default ``a = 0.05`` a swinging
block of the default meat keeps the small-step explicit amplitude within the tolerance of
``tests/tissue/test_massspring.py``, and the stiffest high modes lose about a tenth of their
amplitude a step; a smaller ``a`` left stiff meat on a finer mesh running away late in the
default episode (docs/benchmarks.md).

The system is solved matrix-free by conjugate gradients with a 3x3 block-Jacobi
preconditioner, started from the last step's dv, to a velocity error ``tolerance_m_s``.

Example:
    >>> import numpy as np
    >>> from cell.tissue.springlaw import TANGENT_COLUMNS
    >>> edges = np.array([[0, 1]])
    >>> tangent = np.zeros((1, TANGENT_COLUMNS))
    >>> tangent[0, TANGENT_DIRECTION] = 1.0  # along x
    >>> tangent[0, TANGENT_STIFFNESS] = 100.0  # N/m
    >>> system = ImplicitSystem(edges, np.array([0.01, 0.01]), np.array([0, 3]),
    ...                         np.array([1, 2]), np.array([0.01, 0.01]))
    >>> force = np.array([1.0, 0.0, 0.0, -1.0, 0.0, 0.0])
    >>> no_load = np.zeros((3, 6))
    >>> system.filter(np.zeros(6), force, tangent, 0.01, np.zeros(3), no_load)
    >>> bool(0.0 < force[0] < 1.0)
    True
"""

from __future__ import annotations

import numpy as np
from numba import njit

from cell.tissue.springlaw import (
    TANGENT_DASHPOT,
    TANGENT_DIRECTION,
    TANGENT_STIFFNESS,
    TANGENT_TENSION_PER_LENGTH,
)

# The step's weights (module docstring): beta on h**2 K dv, theta on h K v, gamma on h D dv.
_BETA, _THETA, _GAMMA = 0, 1, 2
# Columns of a spring's blocks, each ``a d d^T + b I``: (a, b) of the system's
# beta h**2 K + gamma h D, then (a, b) of K alone.
_SYSTEM, _STIFFNESS, _BLOCK_COLUMNS = 0, 2, 4
_ALONG, _ACROSS = 0, 1


class ImplicitSystem:
    """The implicit update of one spring lattice's vertices (module docstring).

    Args:
        edges: (E, 2) vertex pairs of the springs.
        mass_kg: (N,) each vertex's mass (MuJoCo's diagonal of M at its three dofs), kg;
            0 for pinned vertices.
        dofadr: (N,) first of each vertex's three dofs, -1 for pinned vertices.
        bodies: (N,) each vertex's body (its row of ``xfrc_applied``).
        body_mass_kg: (N,) those bodies' masses (their weight), kg.
        dissipation: ``a`` of the module docstring; 0 for the trapezoidal rule.
        tolerance_m_s: the conjugate gradients stop when the residual's velocity error, root
            mean square over the vertices' mass, is below it, m/s.
        max_iterations: their cap.

    Attributes:
        iterations: conjugate gradient iterations of the last solve.
        velocity_change: (N, 3) the last dv, m/s, the next solve's start.
    """

    def __init__(self, edges: np.ndarray, mass_kg: np.ndarray, dofadr: np.ndarray,
                 bodies: np.ndarray, body_mass_kg: np.ndarray, dissipation: float = 0.05,
                 tolerance_m_s: float = 1e-4, max_iterations: int = 100) -> None:
        self.edges = np.ascontiguousarray(edges, dtype=np.int64)
        self.mass_kg = np.asarray(mass_kg, dtype=float)
        self.dofadr = np.asarray(dofadr, dtype=np.int64)
        self.bodies = np.asarray(bodies, dtype=np.int64)
        self.body_mass_kg = np.asarray(body_mass_kg, dtype=float)
        self.dissipation = dissipation
        self._weights = np.empty(3)
        self._weights[_BETA] = (1.0 + dissipation) ** 2 / 4.0
        self._weights[_THETA] = dissipation
        self._weights[_GAMMA] = 0.5 + dissipation
        self.tolerance_m_s = tolerance_m_s
        self.max_iterations = max_iterations
        self.iterations = 0
        n = len(self.dofadr)
        self.velocity_change = np.zeros((n, 3))
        self._work = np.zeros((7, n, 3))
        self._inverse = np.zeros((n, 3, 3))
        self._blocks = np.zeros((len(self.edges), _BLOCK_COLUMNS))

    def reset(self) -> None:
        """Forget the last solve (a new state)."""
        self.velocity_change[:] = 0.0

    def filter(self, qvel: np.ndarray, qfrc: np.ndarray, tangent: np.ndarray,
               timestep_s: float, gravity: np.ndarray, xfrc_applied: np.ndarray,
               refresh: bool = True) -> None:
        """Replace the vertices' forces in ``qfrc`` (N) by ``M dv / h - e``, dv the implicit
        update from velocities ``qvel`` over ``timestep_s`` with the springs' ``tangent``
        rows (:func:`~cell.tissue.springlaw.muscle_forces`) under the forces in ``qfrc`` and
        e: the weight under ``gravity`` (m/s^2) and ``xfrc_applied`` (MuJoCo's). The
        preconditioner is kept from the last call unless ``refresh`` (with
        the springs' tangent: it need only be near the system's diagonal)."""
        work = self._work
        _external(self.body_mass_kg, gravity, xfrc_applied, self.bodies, self.dofadr,
                  work[6])
        self.iterations = _implicit_filter(
            qvel, qfrc, work[6], self.dofadr, self.mass_kg, self.edges, tangent, timestep_s,
            self._weights, self.tolerance_m_s, self.max_iterations, self.velocity_change,
            work, self._inverse, self._blocks, refresh)


@njit(cache=True, fastmath=False)
def _external(body_mass: np.ndarray, gravity: np.ndarray, xfrc: np.ndarray,
              bodies: np.ndarray, dofadr: np.ndarray, out: np.ndarray) -> None:
    """e of every vertex into ``out`` (N), zero for pinned vertices."""
    for i in range(dofadr.shape[0]):
        for k in range(3):
            out[i, k] = (body_mass[i] * gravity[k] + xfrc[bodies[i], k]) if dofadr[i] >= 0 \
                else 0.0


@njit(cache=True, fastmath=False)
def _edge_blocks(tangent: np.ndarray, h: float, weights: np.ndarray, blocks: np.ndarray
                 ) -> None:
    """Every spring's blocks, each ``a d d^T + b I``: (a, b) of beta h**2 K + gamma h D,
    then of K, into ``blocks`` (E, 4)."""
    beta = weights[_BETA] * h * h
    for e in range(tangent.shape[0]):
        axial = max(tangent[e, TANGENT_STIFFNESS], 0.0)
        lateral = max(tangent[e, TANGENT_TENSION_PER_LENGTH], 0.0)
        blocks[e, _SYSTEM + _ALONG] = (weights[_GAMMA] * h * tangent[e, TANGENT_DASHPOT]
                                       + beta * (axial - lateral))
        blocks[e, _SYSTEM + _ACROSS] = beta * lateral
        blocks[e, _STIFFNESS + _ALONG] = axial - lateral
        blocks[e, _STIFFNESS + _ACROSS] = lateral


@njit(cache=True, fastmath=False)
def _apply(x: np.ndarray, out: np.ndarray, mass: np.ndarray, free: np.ndarray,
           edges: np.ndarray, tangent: np.ndarray, blocks: np.ndarray, column: int) -> None:
    """out = (M + beta h**2 K + gamma h D) x with ``column`` ``_SYSTEM``, or K x with
    ``_STIFFNESS`` (no M); pinned rows zero."""
    scale = 1.0 if column == _SYSTEM else 0.0
    for i in range(x.shape[0]):
        for k in range(3):
            out[i, k] = scale * mass[i] * x[i, k]
    for e in range(edges.shape[0]):
        i = edges[e, 0]
        j = edges[e, 1]
        a = blocks[e, column + _ALONG]
        b = blocks[e, column + _ACROSS]
        rx = x[i, 0] - x[j, 0]
        ry = x[i, 1] - x[j, 1]
        rz = x[i, 2] - x[j, 2]
        dx = tangent[e, TANGENT_DIRECTION]
        dy = tangent[e, TANGENT_DIRECTION + 1]
        dz = tangent[e, TANGENT_DIRECTION + 2]
        along = a * (dx * rx + dy * ry + dz * rz)
        yx = along * dx + b * rx
        yy = along * dy + b * ry
        yz = along * dz + b * rz
        out[i, 0] += yx
        out[i, 1] += yy
        out[i, 2] += yz
        out[j, 0] -= yx
        out[j, 1] -= yy
        out[j, 2] -= yz
    for i in range(x.shape[0]):
        if not free[i]:
            out[i, 0] = out[i, 1] = out[i, 2] = 0.0


@njit(cache=True, fastmath=False)
def _precondition(inverse: np.ndarray, r: np.ndarray, z: np.ndarray) -> float:
    """z = P^-1 r (3x3 blocks); returns r . z."""
    dot = 0.0
    for i in range(r.shape[0]):
        for k in range(3):
            z[i, k] = (inverse[i, k, 0] * r[i, 0] + inverse[i, k, 1] * r[i, 1]
                       + inverse[i, k, 2] * r[i, 2])
            dot += r[i, k] * z[i, k]
    return dot


@njit(cache=True, fastmath=False)
def _invert_symmetric(block: np.ndarray) -> None:
    """Invert a symmetric positive definite 3x3 ``block`` in place (cofactors)."""
    a, b, c = block[0, 0], block[0, 1], block[0, 2]
    d, e, f = block[1, 1], block[1, 2], block[2, 2]
    c00 = d * f - e * e
    c01 = c * e - b * f
    c02 = b * e - c * d
    inv_det = 1.0 / (a * c00 + b * c01 + c * c02)
    block[0, 0] = c00 * inv_det
    block[0, 1] = block[1, 0] = c01 * inv_det
    block[0, 2] = block[2, 0] = c02 * inv_det
    block[1, 1] = (a * f - c * c) * inv_det
    block[1, 2] = block[2, 1] = (b * c - a * e) * inv_det
    block[2, 2] = (a * d - b * b) * inv_det


@njit(cache=True, fastmath=False)
def _block_inverses(mass: np.ndarray, free: np.ndarray, edges: np.ndarray,
                    tangent: np.ndarray, blocks: np.ndarray, inverse: np.ndarray) -> None:
    """The inverses of the 3x3 diagonal blocks of the system (identity when pinned)."""
    inverse[:] = 0.0
    for i in range(mass.shape[0]):
        for k in range(3):
            inverse[i, k, k] = mass[i]
    for e in range(edges.shape[0]):
        a = blocks[e, _SYSTEM + _ALONG]
        b = blocks[e, _SYSTEM + _ACROSS]
        for end in range(2):
            i = edges[e, end]
            for k in range(3):
                inverse[i, k, k] += b
                for m in range(3):
                    inverse[i, k, m] += (a * tangent[e, TANGENT_DIRECTION + k]
                                         * tangent[e, TANGENT_DIRECTION + m])
    for i in range(mass.shape[0]):
        if free[i]:
            _invert_symmetric(inverse[i])
        else:
            inverse[i] = np.eye(3)


@njit(cache=True, fastmath=False)
def _implicit_filter(qvel: np.ndarray, qfrc: np.ndarray, external: np.ndarray,
                     dofadr: np.ndarray, mass: np.ndarray, edges: np.ndarray,
                     tangent: np.ndarray, h: float, weights: np.ndarray, tolerance: float,
                     max_iterations: int, dv: np.ndarray, work: np.ndarray,
                     inverse: np.ndarray, blocks: np.ndarray, refresh: bool) -> int:
    """Solve for dv by preconditioned conjugate gradients from the last dv and write
    M dv / h - e into ``qfrc``; returns the iterations."""
    n = dofadr.shape[0]
    free = dofadr >= 0
    v, rhs, r, z, p, q = work[0], work[1], work[2], work[3], work[4], work[5]
    _edge_blocks(tangent, h, weights, blocks)
    for i in range(n):
        for k in range(3):
            v[i, k] = qvel[dofadr[i] + k] if free[i] else 0.0
    _apply(v, q, mass, free, edges, tangent, blocks, _STIFFNESS)
    for i in range(n):
        for k in range(3):
            rhs[i, k] = (h * (qfrc[dofadr[i] + k] + external[i, k]
                              - weights[_THETA] * h * q[i, k])
                         if free[i] else 0.0)
            if not free[i]:
                dv[i, k] = 0.0
    if refresh:
        _block_inverses(mass, free, edges, tangent, blocks, inverse)
    _apply(dv, q, mass, free, edges, tangent, blocks, _SYSTEM)
    scale = 0.0
    for i in range(n):
        scale += mass[i]
        for k in range(3):
            r[i, k] = rhs[i, k] - q[i, k]
    rz = _precondition(inverse, r, z)
    p[:] = z
    iterations = 0
    # r . z is about the mass-weighted square of the velocity error: an absolute bound, for
    # the springs' forces often balance others (gravity, contacts) and a bound relative to
    # them would leave the tissue creeping at rest.
    while rz > tolerance * tolerance * scale and iterations < max_iterations:
        _apply(p, q, mass, free, edges, tangent, blocks, _SYSTEM)
        pq = 0.0
        for i in range(n):
            for k in range(3):
                pq += p[i, k] * q[i, k]
        if pq <= 0.0:
            break
        alpha = rz / pq
        for i in range(n):
            for k in range(3):
                dv[i, k] += alpha * p[i, k]
                r[i, k] -= alpha * q[i, k]
        rz_new = _precondition(inverse, r, z)
        beta = rz_new / rz
        rz = rz_new
        for i in range(n):
            for k in range(3):
                p[i, k] = z[i, k] + beta * p[i, k]
        iterations += 1
    for i in range(n):
        if free[i]:
            for k in range(3):
                qfrc[dofadr[i] + k] = mass[i] * dv[i, k] / h - external[i, k]
    return iterations
