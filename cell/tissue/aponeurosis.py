"""The aponeurosis: one binding per facing vertex pair, and the rules that release it.

A binding is either a spring of the paper's law (stiffness in N/m and a dashpot, applied as
forces on the two vertices) or a soft MuJoCo ``connect`` equality (its stiffness then scales
with the vertex masses, so it has no law in N/m). It is released by the knife (its segment
crosses the blade box), by tearing (stretched past a length, or loaded past a pull-off force),
or by force (in contact with the knife and loaded past the measured cutting force, paper
Sec. 4.3); every release is recorded with its time and rule.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import mujoco
import numpy as np
from numba import njit

from cell.errors import InputError

# Columns of the hooked bindings' pull on the blade: the force (N), then the moment (N m)
# about the blade centre, each three wide.
_FORCE, _MOMENT = 0, 3


class ReleaseRule(StrEnum):
    """Why a binding let go."""

    KNIFE = "knife"
    TEARING = "tearing"
    FORCE = "force"


class BindingLaw(StrEnum):
    """How a binding pulls its two vertices together."""

    SPRING = "spring"
    CONSTRAINT = "constraint"


@dataclass(frozen=True)
class BindingRecord:
    """One binding's story: its vertex pair, rest length (m) and release (time s, rule)."""

    index: int
    round_vertex: int
    shank_vertex: int
    rest_length_m: float
    released_at_s: float | None
    released_by: ReleaseRule | None


class Aponeurosis:
    """The bindings between the round and the shank, and their release.

    Args:
        model: the compiled scene.
        round_vertices, shank_vertices: (P,) flex vertex ids (into ``flexvert_xpos``) of the
            two vertices of each binding.
        round_bodies, shank_bodies: (P,) their body ids: a vertex body with three
            world-aligned slide joints, or the static body a pinned vertex belongs to.
        pairs: (P, 2) vertex indices (round, shank) in the muscle meshes.
        law: spring (``stiffness_n_m``, ``damping_n_s_m``) or constraint.
        equality_ids: (P,) ids of the binding ``connect`` equalities (constraint law only).

    Example:
        >>> import mujoco
        >>> from cell.sim.assembly import build_scene
        >>> from cell.sim.scenario import Scenario
        >>> from cell.tissue.geometry import MuscleShape
        >>> scene = build_scene(Scenario(tissue=MuscleShape(cell_size_m=0.05)), robots=False)
        >>> apo, data = scene.aponeurosis, mujoco.MjData(scene.model)
        >>> mujoco.mj_forward(scene.model, data)
        >>> apo.release_by_tearing(data, time_s=1.0, stretch_m=0.01).tolist()  # all at rest
        []
        >>> apo.release(data, [0, 1], 2.0, ReleaseRule.KNIFE).tolist()
        [0, 1]
        >>> apo.released_counts()
        {'knife': 2, 'tearing': 0, 'force': 0}
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        round_vertices: np.ndarray,
        shank_vertices: np.ndarray,
        round_bodies: np.ndarray,
        shank_bodies: np.ndarray,
        pairs: np.ndarray,
        law: BindingLaw = BindingLaw.SPRING,
        stiffness_n_m: float = 50.0,
        damping_n_s_m: float = 0.0,
        equality_ids: np.ndarray | None = None,
    ) -> None:
        self.law = BindingLaw(law)
        if self.law is BindingLaw.CONSTRAINT and equality_ids is None:
            raise InputError(None, "equality_ids",
                             "the constraint law needs the bindings' equality ids")
        self.equality_ids = np.asarray([] if equality_ids is None else equality_ids, dtype=int)
        self.round_vertices = np.asarray(round_vertices, dtype=int)
        self.shank_vertices = np.asarray(shank_vertices, dtype=int)
        self.round_bodies = np.asarray(round_bodies, dtype=int)
        self.shank_bodies = np.asarray(shank_bodies, dtype=int)
        # Pinned vertices have no dofs: zero velocity, and their forces go to the fixture.
        self._round_free = model.body_dofnum[self.round_bodies] == 3
        self._shank_free = model.body_dofnum[self.shank_bodies] == 3
        self._round_dof = np.where(self._round_free, model.body_dofadr[self.round_bodies], -1)
        self._shank_dof = np.where(self._shank_free, model.body_dofadr[self.shank_bodies], -1)
        self._tension = np.zeros(len(self.round_bodies))
        self._on_blade = np.zeros(6)
        self.pairs = np.asarray(pairs, dtype=int)
        self.stiffness_n_m = stiffness_n_m
        self.damping_n_s_m = damping_n_s_m
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        mujoco.mj_flex(model, data)
        self.rest_length_m = self.lengths(data)
        self.released_at_s = np.full(len(self.pairs), np.nan)
        self.released_by: list[ReleaseRule | None] = [None] * len(self.pairs)
        self.hooked = np.zeros(len(self.pairs), dtype=bool)
        self.hook_local = np.zeros((len(self.pairs), 3))
        self.track_blade(np.zeros(3), np.eye(3))

    def __len__(self) -> int:
        return len(self.pairs)

    def reset(self, data: mujoco.MjData) -> None:
        """Bind every pair again (state and record), nothing hooked, the blade at its
        initial guess."""
        data.eq_active[self.equality_ids] = 1
        self.hooked[:] = False
        self.hook_local[:] = 0.0
        self.released_at_s[:] = np.nan
        self.released_by = [None] * len(self)
        self.track_blade(np.zeros(3), np.eye(3))

    @property
    def bound(self) -> np.ndarray:
        """(P,) bool: which bindings still hold."""
        return np.isnan(self.released_at_s)

    def endpoints(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """World positions (P, 3) of the round and shank vertex of every binding, m."""
        return data.flexvert_xpos[self.round_vertices], data.flexvert_xpos[self.shank_vertices]

    def lengths(self, data: mujoco.MjData) -> np.ndarray:
        """(P,) current distance between the two vertices of every binding, m."""
        a, b = self.endpoints(data)
        return np.linalg.norm(b - a, axis=1)

    def track_blade(self, blade_pos: np.ndarray, blade_mat: np.ndarray) -> None:
        """Where the blade is now (world position, m, and rotation): hooked bindings follow
        it."""
        self._blade_pos = np.asarray(blade_pos, float).copy()
        self._blade_rot = np.asarray(blade_mat, float).reshape(3, 3).copy()

    def hook(self, data: mujoco.MjData, under_blade: np.ndarray) -> None:
        """Hook the bound bindings newly under the blade on its edge: from now on their
        middle moves with the blade, so the blade stretches them until they are cut."""
        new = under_blade & self.bound & ~self.hooked
        if new.any():
            a, b = self.endpoints(data)
            middle = 0.5 * (a[new] + b[new])
            self.hook_local[new] = (middle - self._blade_pos) @ self._blade_rot
            self.hooked |= new

    def _springs(self, data: mujoco.MjData, apply: bool) -> np.ndarray:
        """Run the binding-spring kernel: (P,) tensions, N; with ``apply`` their forces go
        into ``qfrc_applied`` and the hooked bindings' pull on the blade into
        ``self._on_blade`` (force N, moment N m about the blade centre)."""
        self._on_blade[:] = 0.0
        _binding_springs(
            data.flexvert_xpos, data.qvel, data.qfrc_applied, self.round_vertices,
            self.shank_vertices, self._round_dof, self._shank_dof, self.rest_length_m,
            self.released_at_s, self.hooked, self.hook_local,
            self._blade_pos, self._blade_rot, self.stiffness_n_m, self.damping_n_s_m, apply,
            self._tension, self._on_blade)
        return self._tension

    def apply_forces(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """Add the spring law's forces to ``data.qfrc_applied`` (nothing for constraints).

        Returns the force (N) the hooked bindings put on the blade and its moment (N m)
        about the blade centre, for the caller to apply to the knife.
        """
        if self.law is not BindingLaw.SPRING:
            return np.zeros(3), np.zeros(3)
        self._springs(data, apply=True)
        return (self._on_blade[_FORCE:_FORCE + 3].copy(),
                self._on_blade[_MOMENT:_MOMENT + 3].copy())

    def forces(self, data: mujoco.MjData) -> np.ndarray:
        """(P,) force carried by every binding, N (0 once released): the spring's force, or
        the norm of the connect constraint's three rows."""
        if self.law is BindingLaw.SPRING:
            return np.abs(self._springs(data, apply=False))
        rows = data.efc_type[: data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY
        squared = np.zeros(data.eq_active.shape[0])
        np.add.at(squared, data.efc_id[: data.nefc][rows], data.efc_force[: data.nefc][rows] ** 2)
        return np.sqrt(squared[self.equality_ids])

    def round_end_force(self, data: mujoco.MjData) -> np.ndarray:
        """Total force (N, world frame) the spring bindings put on their round ends, pinned
        ones too (MuJoCo applies those to nothing; they act on the fixture): what MuJoCo's
        force sensors leave out of the fixture's load. Zero under the constraint law, whose
        equality forces MuJoCo counts itself."""
        count = len(self)
        if self.law is not BindingLaw.SPRING or count == 0:
            return np.zeros(3)
        # The kernel on dofs of the bindings' own: round ends at 3p, shank ends after them.
        ends = 3 * np.arange(count)
        shank = np.where(self._shank_free, 3 * count + ends, -1)
        qvel = np.zeros(6 * count)
        for k in range(3):
            free = self._round_dof >= 0
            qvel[ends[free] + k] = data.qvel[self._round_dof[free] + k]
            qvel[shank[self._shank_free] + k] = data.qvel[self._shank_dof[self._shank_free] + k]
        qfrc = np.zeros(6 * count)
        _binding_springs(data.flexvert_xpos, qvel, qfrc, self.round_vertices,
                         self.shank_vertices, ends, shank, self.rest_length_m,
                         self.released_at_s, self.hooked, self.hook_local, self._blade_pos,
                         self._blade_rot, self.stiffness_n_m, self.damping_n_s_m, True,
                         np.zeros(count), np.zeros(6))
        return qfrc[:3 * count].reshape(count, 3).sum(axis=0)

    def release(self, data: mujoco.MjData, which: np.ndarray, time_s: float,
                rule: ReleaseRule) -> np.ndarray:
        """Release the still-bound bindings selected by ``which`` (bool mask or indices);
        returns the indices released now."""
        mask = np.zeros(len(self), dtype=bool)
        mask[which] = True
        newly = np.flatnonzero(mask & self.bound)
        if self.law is BindingLaw.CONSTRAINT:
            data.eq_active[self.equality_ids[newly]] = 0
        self.hooked[newly] = False
        self.released_at_s[newly] = time_s
        for i in newly:
            self.released_by[i] = rule
        return newly

    def under_blade(self, data: mujoco.MjData, blade_pos: np.ndarray, blade_mat: np.ndarray,
                    blade_half_size_m: np.ndarray, margin_m: float) -> np.ndarray:
        """(P,) bool: bindings whose segment crosses the blade box grown by ``margin_m``.

        A segment test (not a plane-crossing test) also catches bindings the blade pushed to
        one side before it reached them.
        """
        a, b = self.endpoints(data)
        rot = np.asarray(blade_mat).reshape(3, 3)
        half = np.asarray(blade_half_size_m) + margin_m
        return segments_cross_box((a - blade_pos) @ rot, (b - blade_pos) @ rot, half)

    def release_by_knife(self, data: mujoco.MjData, time_s: float,
                         under_blade: np.ndarray) -> np.ndarray:
        """Release the bindings under the blade (paper Sec. 4.2)."""
        return self.release(data, under_blade, time_s, ReleaseRule.KNIFE)

    def release_by_tearing(self, data: mujoco.MjData, time_s: float, stretch_m: float,
                           force_n: float | None = None) -> np.ndarray:
        """Release the bindings stretched more than ``stretch_m`` beyond their rest length, or
        loaded above the pull-off strength ``force_n`` when given (paper Sec. 4.1)."""
        torn = self.lengths(data) - self.rest_length_m > stretch_m
        if force_n is not None:
            torn |= self.forces(data) > force_n
        return self.release(data, torn, time_s, ReleaseRule.TEARING)

    def release_by_force(self, data: mujoco.MjData, time_s: float, under_blade: np.ndarray,
                         threshold_n: float) -> np.ndarray:
        """Paper Sec. 4.3: release the bindings in contact with the blade (under it now, or
        hooked on its edge) whose force exceeds the measured cutting force ``threshold_n``
        at this moment."""
        cut = (under_blade | self.hooked) & (self.forces(data) > threshold_n)
        return self.release(data, cut, time_s, ReleaseRule.FORCE)

    def records(self) -> list[BindingRecord]:
        """One :class:`BindingRecord` per binding."""
        return [
            BindingRecord(
                index=i,
                round_vertex=int(self.pairs[i, 0]),
                shank_vertex=int(self.pairs[i, 1]),
                rest_length_m=float(self.rest_length_m[i]),
                released_at_s=None if np.isnan(self.released_at_s[i])
                else float(self.released_at_s[i]),
                released_by=self.released_by[i],
            )
            for i in range(len(self))
        ]

    def released_counts(self) -> dict[str, int]:
        """Number of bindings released by each rule."""
        return {rule.value: sum(r is rule for r in self.released_by) for rule in ReleaseRule}


@njit(cache=True)
def segments_cross_box(start: np.ndarray, end: np.ndarray, half_size: np.ndarray) -> np.ndarray:
    """(N,) bool: does segment ``start[i] -> end[i]`` meet the axis-aligned box
    ``|x| <= half_size``? Points are in the box frame (slab test). Compiled: the release rules
    and the envs' sensing run it at every control step."""
    crosses = np.zeros(len(start), dtype=np.bool_)
    for i in range(len(start)):
        enter, leave = -np.inf, np.inf
        for k in range(3):
            direction = end[i, k] - start[i, k]
            if direction == 0.0:  # parallel to the slab: inside it or a miss
                if not abs(start[i, k]) <= half_size[k]:
                    break
                continue
            t1 = (-half_size[k] - start[i, k]) / direction
            t2 = (half_size[k] - start[i, k]) / direction
            if np.isnan(t1) or np.isnan(t2):
                break
            enter, leave = max(enter, min(t1, t2)), min(leave, max(t1, t2))
        else:
            crosses[i] = enter <= leave and leave >= 0.0 and enter <= 1.0
    return crosses


@njit(cache=True)
def _binding_springs(xpos: np.ndarray, qvel: np.ndarray, qfrc: np.ndarray,
                     round_vertex: np.ndarray, shank_vertex: np.ndarray, round_dof: np.ndarray,
                     shank_dof: np.ndarray, rest: np.ndarray, released_at: np.ndarray,
                     hooked: np.ndarray, hook_local: np.ndarray, blade_pos: np.ndarray,
                     blade_rot: np.ndarray, stiffness: float, damping: float, apply: bool,
                     tension_out: np.ndarray, on_blade: np.ndarray) -> None:
    """Tension of every binding spring (a to its hook point to b; the hook is the middle of a
    free binding and rides on the blade for a hooked one) and, with ``apply``, its forces on
    the two vertices' dofs and the hooked ones' force and moment on the blade.

    Scalars and tuples throughout: a 3-vector array per operation cost a heap allocation
    each, most of the kernel's time."""
    for p in range(len(rest)):
        if not math.isnan(released_at[p]):
            tension_out[p] = 0.0
            continue
        i, j = round_vertex[p], shank_vertex[p]
        ax, ay, az = xpos[i, 0], xpos[i, 1], xpos[i, 2]
        bx, by, bz = xpos[j, 0], xpos[j, 1], xpos[j, 2]
        if hooked[p]:
            u, v, w = hook_local[p, 0], hook_local[p, 1], hook_local[p, 2]
            hx = blade_pos[0] + blade_rot[0, 0] * u + blade_rot[0, 1] * v + blade_rot[0, 2] * w
            hy = blade_pos[1] + blade_rot[1, 0] * u + blade_rot[1, 1] * v + blade_rot[1, 2] * w
            hz = blade_pos[2] + blade_rot[2, 0] * u + blade_rot[2, 1] * v + blade_rot[2, 2] * w
        else:
            hx, hy, hz = 0.5 * (ax + bx), 0.5 * (ay + by), 0.5 * (az + bz)
        len_a = max(math.sqrt((hx - ax) ** 2 + (hy - ay) ** 2 + (hz - az) ** 2), 1e-12)
        len_b = max(math.sqrt((hx - bx) ** 2 + (hy - by) ** 2 + (hz - bz) ** 2), 1e-12)
        span = max(math.sqrt((bx - ax) ** 2 + (by - ay) ** 2 + (bz - az) ** 2), 1e-12)
        rate = 0.0
        for k, along in enumerate(((bx - ax) / span, (by - ay) / span, (bz - az) / span)):
            if shank_dof[p] >= 0:
                rate += qvel[shank_dof[p] + k] * along
            if round_dof[p] >= 0:
                rate -= qvel[round_dof[p] + k] * along
        tension = stiffness * (len_a + len_b - rest[p]) + damping * rate
        tension_out[p] = tension
        if not apply:
            continue
        on_a = (tension * (hx - ax) / len_a, tension * (hy - ay) / len_a,
                tension * (hz - az) / len_a)
        on_b = (tension * (hx - bx) / len_b, tension * (hy - by) / len_b,
                tension * (hz - bz) / len_b)
        for k in range(3):
            if round_dof[p] >= 0:
                qfrc[round_dof[p] + k] += on_a[k]
            if shank_dof[p] >= 0:
                qfrc[shank_dof[p] + k] += on_b[k]
        if hooked[p]:
            px, py, pz = -(on_a[0] + on_b[0]), -(on_a[1] + on_b[1]), -(on_a[2] + on_b[2])
            rx, ry, rz = hx - blade_pos[0], hy - blade_pos[1], hz - blade_pos[2]
            on_blade[_FORCE] += px
            on_blade[_FORCE + 1] += py
            on_blade[_FORCE + 2] += pz
            on_blade[_MOMENT] += ry * pz - rz * py
            on_blade[_MOMENT + 1] += rz * px - rx * pz
            on_blade[_MOMENT + 2] += rx * py - ry * px
