"""The reduced model of a cut test: the force on the blade from the edge's logged path, the
block, the blade and the cutting model, without a mesh or MuJoCo.

The cut plane is a cohesive zone of toughness G and the cut faces press on the blade with the
pressure p of the cutting model (:mod:`cell.tissue.cutmodel`, whose force law this applies):

- The material along the edge is cut into ``bins`` strips across the edge (material
  coordinate ``u`` along the edge direction, fixed to the block, so that a sawing stroke
  meets the strips it cut before). Each strip remembers its crack front, the deepest depth
  below the block's top face that the edge has reached in it.
- At each sample the edge cuts fresh material in the strips where it lies inside the block
  and deeper than their front; the engaged length is the width of those strips. There the
  edge force of :func:`~cell.tissue.cutmodel.edge_force` acts, each strip with the layer
  factor and indentation ramp of its own depth. An edge that moves back up, pauses, or saws
  sideways at a depth it reached before cuts nothing.
- The blade's face in the material spans, in each strip the blade covers inside the block's
  footprint, from the edge up to the top face: its area drags with
  :func:`~cell.tissue.cutmodel.face_friction_force`, also while the blade moves back out;
  the wedge's drag weights each strip's face by how far the blade opens the cut there
  (:func:`~cell.measure.wedge.wedge_height_m`).

The edge's velocity is the time derivative of the logged path (second-order differences on
the irregular samples). The blade enters through the top face: its cutting direction (in its
plane, across its edge) points down.

Example:
    >>> from cell.measure.cuts import Blade, Block, CutTest
    >>> from cell.tissue.cutmodel import CuttingParams
    >>> block = Block((0.06, 0.04, 0.03))
    >>> blade = Blade(0.12, 0.0015, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
    >>> t = np.linspace(0.0, 2.0, 201)
    >>> edge = np.column_stack([0.03 + 0 * t, 0.02 + 0 * t, 0.035 - 0.01 * t])
    >>> test = CutTest("press", t, edge, np.zeros((201, 3)), None)
    >>> forces = reduced_cut_forces(test, block, blade, CuttingParams(1000.0))
    >>> round(float(forces.total_n[150, 2]), 3)  # G times the block's 0.04 m width
    40.0
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cell.measure import wedge
from cell.measure.cuts import Blade, Block, CutTest
from cell.tissue.cutmodel import (
    CuttingParams,
    edge_force,
    face_friction_force,
    path_velocity_m_s,
    push_and_slice,
)
from cell.tissue.edgestate import EdgeState, edge_terms

#: Strips across the edge that remember their crack front: the engaged length is resolved to
#: the block's extent along the edge over this many.
STRIPS = 96

#: An advancing edge cuts a strip where it is no more than this above the strip's crack front:
#: a logged position's noise (encoders read to micrometres) must not make a sample that the
#: edge reached while sinking look like one it had passed already.
FRONT_TOLERANCE_M = 1e-5
#: A test saws when its edge travels along itself at least this fraction of its travel into the
#: block while in the material; a press cut's travel along itself is its path's noise.
SLIDING_RATIO = 0.1


@dataclass(frozen=True, eq=False)
class CutForces:
    """The reduced model's forces on the blade over one cut test, block frame.

    Attributes:
        edge_n: (n, 3) force of the material on the edge, N.
        faces_n: (n, 3) friction of the cut faces on the blade's faces, N.
        engaged_length_m: (n,) length of edge cutting fresh material, m.
        face_area_m2: (n,) area of one face of the blade inside the material, m^2.
        depth_m: (n,) depth of the edge's midpoint below the block's top face, m.
    """

    edge_n: np.ndarray
    faces_n: np.ndarray
    engaged_length_m: np.ndarray
    face_area_m2: np.ndarray
    depth_m: np.ndarray

    @property
    def total_n(self) -> np.ndarray:
        """(n, 3) the force of the block on the blade, N (no sensor offset)."""
        return self.edge_n + self.faces_n


def cutting_direction(blade: Blade) -> np.ndarray:
    """The unit direction in the blade's plane, across its edge, that points down (into the
    block's top face); for a blade whose edge is vertical, along the blade's plane's +x side.

    Example:
        >>> blade = Blade(0.1, 1e-3, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
        >>> cutting_direction(blade).tolist()
        [0.0, 0.0, -1.0]
    """
    across = np.cross(np.asarray(blade.blade_normal), np.asarray(blade.edge_direction))
    across /= np.linalg.norm(across)
    sign = -np.sign(across[2]) if abs(across[2]) > 1e-9 else np.sign(across[0] or 1.0)
    return across * sign


def edge_velocity_m_s(test: CutTest) -> np.ndarray:
    """(n, 3) velocity of the edge's midpoint, m/s: the logged path's derivative, second order
    on the irregular samples (as the full simulation's edge term takes it)."""
    return path_velocity_m_s(test.time_s, test.edge_m)


def _strips(block: Block, edge: np.ndarray, strips: int) -> tuple[np.ndarray, float]:
    """Centres (material coordinate u along the edge, m) and width of the strips over the
    block's extent along ``edge``."""
    corners = np.array([[x, y, z] for x in (0.0, block.size_m[0]) for y in (0.0, block.size_m[1])
                        for z in (0.0, block.size_m[2])])
    u = corners @ edge
    width = (u.max() - u.min()) / strips
    return u.min() + width * (np.arange(strips) + 0.5), float(width)


@dataclass(frozen=True, eq=False)
class CutKinematics:
    """What a cut test's path does to the block, whatever the cutting model: per sample and
    strip, where the edge cuts fresh material and at what depth; per sample, the edge's push
    and slice velocities and the blade's face area in the material. A fit computes it once
    per test and evaluates many cutting models on it.

    Attributes:
        fresh: (n, s) whether the edge cuts fresh material in the strip at the sample.
        depth_m: (n, s) depth of the edge below the block's top face in each strip, m.
        strip_width_m: width of a strip along the edge, m.
        push_m_s: (n, 3) the edge's velocity across itself in the blade's plane, m/s.
        slice_m_s: (n, 3) the edge's velocity along itself, m/s.
        face_area_m2: (n,) area of one face of the blade inside the material, m^2.
        middle_depth_m: (n,) depth of the edge's midpoint below the top face, m.
        inside: (n, s) whether the edge is in the material in the strip at the sample.
        along_m: (n,) the edge's midpoint along the edge direction, m.
        down: (3,) the cutting direction (:func:`cutting_direction`).
        edge: (3,) the edge's direction.
        whole: the kinematics of every sample, where these are some of them (:meth:`rows`):
            the terms with a state (the loading, the edge's friction) follow the whole path.
        samples: the indices of these samples in ``whole``.
        wedged_area_m2: (n,) ``face_area_m2`` weighted by the cut's opening, m^2.
        opening_strain: the faces' strain at full opening
            (:func:`~cell.measure.wedge.opening_strain`).
    """

    fresh: np.ndarray
    depth_m: np.ndarray
    strip_width_m: float
    push_m_s: np.ndarray
    slice_m_s: np.ndarray
    face_area_m2: np.ndarray
    middle_depth_m: np.ndarray
    inside: np.ndarray
    along_m: np.ndarray
    down: np.ndarray
    edge: np.ndarray
    whole: CutKinematics | None = None
    samples: np.ndarray | None = None
    wedged_area_m2: np.ndarray | None = None
    opening_strain: float = 0.0

    @classmethod
    def of(cls, test: CutTest, block: Block, blade: Blade, strips: int = STRIPS
           ) -> CutKinematics:
        """The kinematics of ``test`` (module docstring)."""
        edge_dir = np.asarray(blade.edge_direction, dtype=float)
        down = cutting_direction(blade)
        centres, width = _strips(block, edge_dir, strips)
        along = centres[None, :] - (test.edge_m @ edge_dir)[:, None]
        covered = np.abs(along) <= 0.5 * blade.edge_length_m
        x, y, z = (test.edge_m[:, k, None] + along * edge_dir[k] for k in range(3))
        bottom, top = block.surfaces_z_m(x, y)
        depth = np.nan_to_num(top - z, nan=-1.0)
        in_footprint = covered & np.isfinite(top)
        inside = in_footprint & (depth > 0.0) & (z >= np.nan_to_num(bottom, nan=np.inf))
        front = np.maximum.accumulate(np.where(inside, depth, -np.inf), axis=0)
        before = np.empty_like(front)
        before[0], before[1:] = -np.inf, front[:-1]
        push, slide = push_and_slice(edge_velocity_m_s(test), edge_dir, blade.blade_normal)
        fresh = inside & (depth > before - FRONT_TOLERANCE_M) & ((push @ down) > 0.0)[:, None]
        rise = abs(float(down[2])) or 1.0
        height = np.where(in_footprint, np.clip(np.minimum(depth, np.nan_to_num(
            top - bottom)), 0.0, None) / rise, 0.0)
        return cls(fresh, depth, width, push, slide, width * height.sum(axis=1),
                   block.top_z_m - test.edge_m[:, 2], inside, test.edge_m @ edge_dir, down,
                   edge_dir, wedged_area_m2=width * wedge.wedge_height_m(blade, height).sum(axis=1),
                   opening_strain=wedge.opening_strain(blade, block))

    def rows(self, samples: np.ndarray) -> CutKinematics:
        """The kinematics at ``samples`` only (indices): the crack fronts were found on the
        whole path, so a thinned test cuts where the whole one does."""
        whole = self.whole or self
        picked = samples if self.samples is None else self.samples[samples]
        return CutKinematics(self.fresh[samples], self.depth_m[samples], self.strip_width_m,
                             self.push_m_s[samples], self.slice_m_s[samples],
                             self.face_area_m2[samples], self.middle_depth_m[samples],
                             self.inside[samples], self.along_m[samples], self.down,
                             self.edge, whole, picked, self.wedged[samples],
                             self.opening_strain)

    @property
    def wedged(self) -> np.ndarray:
        """(n,) :attr:`wedged_area_m2` (zero where kinematics were made without it), m^2."""
        return (np.zeros_like(self.face_area_m2) if self.wedged_area_m2 is None
                else self.wedged_area_m2)

    @property
    def slides(self) -> bool:
        """Whether the edge slides along itself while in the material: its travel along itself
        at least :data:`SLIDING_RATIO` of its travel into the block."""
        cutting = self.inside.any(axis=1)
        if not cutting.any():
            return False
        along, into = (float(np.ptp(v[cutting])) for v in (self.along_m, self.middle_depth_m))
        return along >= SLIDING_RATIO * into

    @property
    def engaged_length_m(self) -> np.ndarray:
        """(n,) length of edge cutting fresh material, m."""
        return self.strip_width_m * self.fresh.sum(axis=1)

    def edge_n(self, cutting: CuttingParams,
               depth_factor: Callable[[np.ndarray], np.ndarray] | None = None) -> np.ndarray:
        """(n, 3) force of the material on the edge, N, its friction along itself included;
        ``depth_factor`` (of the strips' depths, (n, s)) in place of the model's own layers
        and ramp (:meth:`CuttingParams.depth_factor`) where given."""
        if cutting.loading_depth_m > 0.0 or cutting.edge_friction > 0.0:
            edge, rubbing = self.edge_terms_n(cutting, depth_factor,
                                              cutting.edge_friction > 0.0)
            return edge + cutting.edge_friction * rubbing
        factor = (cutting.depth_factor if depth_factor is None else depth_factor)(self.depth_m)
        # Each strip's own factor weights its length, so the law runs once per sample.
        weighted = self.strip_width_m * np.where(self.fresh, factor, 0.0).sum(axis=1)
        return edge_force(cutting.uniform(), weighted, self.push_m_s, self.slice_m_s,
                          self.middle_depth_m)

    def edge_terms_n(self, cutting: CuttingParams,
                     depth_factor: Callable[[np.ndarray], np.ndarray] | None = None,
                     rubbing: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """The edge's force without its friction along itself and that friction per unit
        of ``edge_friction`` (:func:`~cell.tissue.edgestate.edge_terms`), (n, 3) each, N:
        found on the whole path, which the terms' state follows."""
        if self.whole is not None:
            edge, rubbed = self.whole.edge_terms_n(cutting, depth_factor, rubbing)
            return edge[self.samples], rubbed[self.samples]
        factor = (cutting.depth_factor if depth_factor is None else depth_factor)(self.depth_m)
        return edge_terms(cutting, EdgeState(
            self.strip_width_m * factor, self.depth_m, self.inside, self.fresh,
            self.push_m_s, self.slice_m_s, self.along_m, self.down, self.edge,
            self.middle_depth_m), rubbing)

    def faces_n(self, cutting: CuttingParams) -> np.ndarray:
        """(n, 3) friction of the cut faces on the blade, N."""
        return face_friction_force(cutting, self.face_area_m2, self.push_m_s, self.slice_m_s,
                                   self.wedged, self.opening_strain)

    def forces(self, cutting: CuttingParams) -> CutForces:
        """The forces of ``cutting`` over the test."""
        return CutForces(self.edge_n(cutting), self.faces_n(cutting), self.engaged_length_m,
                         self.face_area_m2, self.middle_depth_m)


def reduced_cut_forces(test: CutTest, block: Block, blade: Blade, cutting: CuttingParams,
                 strips: int = STRIPS) -> CutForces:
    """The forces on the blade over ``test`` (module docstring).

    Example:
        >>> from cell.measure.cuts import Blade, Block, CutTest
        >>> t = np.linspace(0.0, 1.0, 11)
        >>> up = np.column_stack([0.03 + 0 * t, 0.02 + 0 * t, 0.02 + 0.01 * t])
        >>> forces = reduced_cut_forces(CutTest("out", t, up, np.zeros((11, 3))), Block((0.06, 0.04,
        ...     0.03)), Blade(0.12, 1e-3, (0, 1, 0), (1, 0, 0)), CuttingParams(800.0))
        >>> float(abs(forces.edge_n).max())  # moving back out cuts nothing
        0.0
    """
    return CutKinematics.of(test, block, blade, strips).forces(cutting)


#: The name of :func:`reduced_cut_forces` in 0.1.0, importable for one release (the full
#: simulation of a cut test is :func:`cell.cuttest.run.simulate_cut`).
simulate_cut = reduced_cut_forces
