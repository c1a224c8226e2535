"""The cutting model: what a blade's edge and faces feel in tissue, as pure numpy functions.

A material file's ``[cutting]`` table (:class:`CuttingParams`) gives the material's
resistance to a blade. Its terms, each a force that the tissue exerts on the blade, in the
frame the caller's vectors are in (the block frame of a cut test, the world frame of the
cell):

- the **edge** (:func:`edge_force`): separating the material costs the toughness G (J/m^2)
  per unit area of new cut, so an edge of engaged length L advancing into the material at
  the push speed v_p does work ``G_eff L v_p``. The push component of the force is
  ``P = G_eff L / sqrt(1 + (eta xi)^2)`` with the slice/push ratio ``xi = v_s / v_p`` and
  the slicing efficiency eta (Atkins, Xu & Humphrey 2004; Reyssat et al. 2012): moving the
  edge along itself lowers the force to sink it. The slice component S takes the rest of the
  fracture work, ``P v_p + S v_s = G_eff L v_p``, so the edge dissipates G per unit area of
  cut whatever the slicing. ``G_eff = G * layer factor(depth) * (v / v_ref)^m * ramp``:
  the factor of the layer the edge is in, the rate factor of the edge's speed v, and the
  indentation ramp ``min(1, depth / indentation_depth_m)`` (the material deforms under the
  edge before the first crack).
- **loading before the crack runs** (``loading_depth_m``,
  :func:`~cell.tissue.edgestate.loaded_edge_force`): the material and the rig deform under
  the edge, which presses on them as a spring until the energy at the edge reaches the
  toughness; the crack then runs, its front ``loading_depth_m`` (times
  the slicing factor, which lowers the load the crack needs) behind the edge. The edge's
  load is ``G L`` times the share of that depth it has sunk past the front: it ramps in
  after first contact and after every stroke that backed out, and holds while the edge
  rests in its cut (the indentation phase of Atkins 2009 and of Jamdagni & Jia).
- **friction along the edge** (``edge_friction``,
  :func:`~cell.tissue.edgestate.edge_friction_state`): the edge's load presses it into the
  material, which drags on it along itself as a Dahl friction (Dahl 1976): the force turns
  over a slip ``edge_slip_m`` of the edge along itself, easing through zero where a sawing
  stroke turns, up to ``edge_friction`` times the load.
- the **faces** (:func:`face_friction_force`): both faces of the blade drag in the cut with
  the shear stress ``mu p`` over the blade's area in the material, opposite to the blade's
  velocity along its faces, also while it moves back out.
- the **wedge** (``face_modulus_pa``, mu E, in :func:`face_friction_force`): the blade's
  thickness t wedges the cut's faces apart, each side of the cut a slab of the material
  (together the block's extent W across the blade) strained by the opening, so the faces
  press with ``E 2 h(s) / W`` where the blade's half-thickness h(s) grows along the bevel
  from the edge's radius to t / 2 (:func:`cell.measure.wedge.wedge_height_m`). Its drag,
  mu times that pressure over the blade's area in the material, grows with the depth of
  blade in the material: quadratically along the bevel, then linearly.

The face pressure p is a parameter of its own (``face_pressure_pa``), not derived from the
modulus: a wedge of thickness t held in a plane cut of depth a is pressed by about
``E t / a``, which falls as the cut deepens, whereas friction measured on blades and needles
in soft tissue grows with the area in the material. Only the product ``mu p`` shows in a
force, so a diagnosis fits the friction coefficient at the given pressure.

Example:
    >>> params = CuttingParams(toughness_j_m2=1000.0)
    >>> edge_force(params, 0.04, (0.0, 0.0, -0.01), (0.0, 0.0, 0.0), 0.01).round(6).tolist()
    [0.0, 0.0, 40.0]
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from cell.errors import MaterialError

#: The causes of a cut test (the cut cause table, docs/measured-data.md), each a term of
#: this model or the blade's sensor: the names the diagnosis of cut tests
#: (:mod:`cell.diagnosis.cut.causes`) and the generator of hidden-effect cut sets share.
CUT_CAUSES = (
    "blade_friction",
    "slicing",
    "rate_dependent_cutting",
    "indentation_stiffness",
    "layered_toughness",
    "blade_force_offset",
    "edge_loading",
    "edge_friction",
    "wedge_friction",
)

#: Speed below which the faces' friction fades linearly to zero instead of flipping sign:
#: a sawing stroke reverses through zero speed, and a force that jumps there makes both the
#: implicit step and a fit's gradient stiff. Far below any cutting speed (mm/s to m/s).
FRICTION_REGULARISATION_M_S = 1e-4

#: Push speeds at or below this do not advance the edge (no new cut, no edge force).
ADVANCE_SPEED_M_S = 1e-9


@dataclass(frozen=True)
class CuttingParams:
    """A material's resistance to a blade: the ``[cutting]`` table of a material file.

    The defaults of the optional terms switch them off, so ``CuttingParams(toughness_j_m2=G)``
    is the plain cut (a constant resistance per unit length of edge); the material file
    ``assets/materials/beef_default.toml`` gives cited values for beef.

    Attributes:
        toughness_j_m2: G, the work to separate the material per unit area of cut, J/m^2
            (N/m: the force of a push cut per metre of engaged edge). > 0.
        face_friction: mu, Coulomb friction coefficient between the blade's faces and the cut
            faces, >= 0.
        face_pressure_pa: p, normal pressure of the cut faces on the blade's faces, Pa, >= 0.
        slicing_efficiency: eta in ``1 / sqrt(1 + (eta xi)^2)``, >= 0; 0 = slicing does not
            lower the force to sink the edge, 1 = Atkins' ideal slicing.
        reference_speed_m_s: v_ref, the edge speed at which G is the toughness, m/s, > 0.
        rate_exponent: m in the rate factor ``(v / v_ref)^m``, in [-1, 1]; 0 = rate
            independent.
        indentation_depth_m: depth over which the edge force ramps from 0 to its full value
            as the edge first sinks into the material (before the first crack), m, >= 0.
        layer_depths_m: depths below the block's top face (or the tissue's surface) where a
            layer ends and the next begins, m, strictly increasing, > 0.
        layer_factors: G's factor in each layer, one more than ``layer_depths_m`` (the first
            from the surface to the first depth, the last below the last depth), each > 0.
        loading_depth_m: depth the edge sinks past the crack front before the crack runs
            (the toughness over the stiffness per unit length of edge), m, >= 0; 0 = the
            edge's load is a cutting force only (module docstring).
        edge_friction: mu_e, the edge's friction along itself per unit of its load, >= 0.
        edge_slip_m: the slip along the edge over which its friction turns, m, > 0.
        face_modulus_pa: mu E, the faces' friction coefficient times the modulus that
            presses them on a blade wedging the cut open, Pa, >= 0; 0 = no wedge.

    Raises:
        MaterialError: naming the key at fault (a value out of range or not finite, layer
            depths not increasing, the wrong number of layer factors).

    Example:
        >>> layered = CuttingParams(toughness_j_m2=800.0, layer_depths_m=(0.01,),
        ...                         layer_factors=(1.0, 2.0))
        >>> layered.layer_factor([0.005, 0.015]).tolist()
        [1.0, 2.0]
    """

    toughness_j_m2: float
    face_friction: float = 0.0
    face_pressure_pa: float = 0.0
    slicing_efficiency: float = 0.0
    reference_speed_m_s: float = 0.01
    rate_exponent: float = 0.0
    indentation_depth_m: float = 0.0
    layer_depths_m: tuple[float, ...] = ()
    layer_factors: tuple[float, ...] = ()
    loading_depth_m: float = 0.0
    edge_friction: float = 0.0
    edge_slip_m: float = 0.001
    face_modulus_pa: float = 0.0

    def __post_init__(self) -> None:
        for name in ("toughness_j_m2", "reference_speed_m_s", "edge_slip_m"):
            _check(name, getattr(self, name), lambda v: v > 0, "> 0")
        for name in ("face_friction", "face_pressure_pa", "slicing_efficiency",
                     "indentation_depth_m", "loading_depth_m", "edge_friction",
                     "face_modulus_pa"):
            _check(name, getattr(self, name), lambda v: v >= 0, ">= 0")
        _check("rate_exponent", self.rate_exponent, lambda v: -1 <= v <= 1, "in [-1, 1]")
        depths = _numbers("layer_depths_m", self.layer_depths_m)
        factors = _numbers("layer_factors", self.layer_factors)
        if depths and not (depths[0] > 0 and all(b > a for a, b in itertools.pairwise(depths))):
            raise MaterialError(None, "layer_depths_m",
                                f"must be > 0 and strictly increasing, got {list(depths)}")
        if (depths or factors) and len(factors) != len(depths) + 1:
            raise MaterialError(None, "layer_factors",
                                f"needs one factor per layer, {len(depths) + 1} for "
                                f"{len(depths)} layer depths, got {len(factors)}")
        if not all(f > 0 for f in factors):
            raise MaterialError(None, "layer_factors", f"must be > 0, got {list(factors)}")
        object.__setattr__(self, "layer_depths_m", depths)
        object.__setattr__(self, "layer_factors", factors)

    def depth_factor(self, depth_m: ArrayLike) -> np.ndarray:
        """G's factor at ``depth_m`` below the surface: the layer's times the indentation
        ramp."""
        return self.layer_factor(depth_m) * self.indentation_ramp(depth_m)

    def uniform(self) -> CuttingParams:
        """This model with the same toughness at every depth (no layers, no indentation
        ramp): for a caller that weights the engaged length by :meth:`depth_factor` itself."""
        return replace(self, layer_depths_m=(), layer_factors=(), indentation_depth_m=0.0)

    def layer_factor(self, depth_m: ArrayLike) -> np.ndarray:
        """G's factor of the layer at ``depth_m`` below the surface (1 without layers)."""
        depth = np.asarray(depth_m, dtype=float)
        if not self.layer_factors:
            return np.ones_like(depth)
        index = np.searchsorted(np.asarray(self.layer_depths_m), depth, side="right")
        return np.asarray(self.layer_factors)[index]

    def rate_factor(self, speed_m_s: ArrayLike) -> np.ndarray:
        """``(v / v_ref)^m`` of the edge's speed (1 at the reference speed)."""
        speed = np.maximum(np.asarray(speed_m_s, dtype=float), ADVANCE_SPEED_M_S)
        return (speed / self.reference_speed_m_s) ** self.rate_exponent

    def indentation_ramp(self, depth_m: ArrayLike) -> np.ndarray:
        """The edge force's share, 0 to 1, while the edge first sinks to
        ``indentation_depth_m`` below the surface (1 everywhere without indentation)."""
        depth = np.asarray(depth_m, dtype=float)
        if self.indentation_depth_m == 0:
            return np.ones_like(depth)
        return np.clip(depth / self.indentation_depth_m, 0.0, 1.0)

    def slicing_factor(self, slice_push_ratio: ArrayLike) -> np.ndarray:
        """``1 / sqrt(1 + (eta xi)^2)``: the push force's share at slice/push ratio xi."""
        xi = np.asarray(slice_push_ratio, dtype=float)
        return 1.0 / np.sqrt(1.0 + (self.slicing_efficiency * xi) ** 2)


def _check(name: str, value: object, holds: Callable[[float], bool], bound: str) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float) or not (
            math.isfinite(value) and holds(value)):
        raise MaterialError(None, name, f"must be a finite number {bound}, got {value!r}")


def _numbers(name: str, values: object) -> tuple[float, ...]:
    if not isinstance(values, list | tuple) or not all(
            isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
            for v in values):
        raise MaterialError(None, name, f"must be a list of finite numbers, got {values!r}")
    return tuple(float(v) for v in values)


def _norm(vectors: np.ndarray) -> np.ndarray:
    return np.sqrt(np.einsum("...i,...i->...", vectors, vectors))


def edge_force(params: CuttingParams, engaged_length_m: ArrayLike,
               push_velocity_m_s: ArrayLike, slice_velocity_m_s: ArrayLike,
               depth_m: ArrayLike) -> np.ndarray:
    """The force the material exerts on the blade's edge, N, shape ``(..., 3)``.

    Args:
        params: the cutting model.
        engaged_length_m: length of edge that cuts fresh material (inside the material, at the
            crack front), m, shape ``(...)``; 0 where the edge is in air or in its own cut.
        push_velocity_m_s: the edge's velocity into the material (the blade's plane,
            perpendicular to the edge), m/s, shape ``(..., 3)``.
        slice_velocity_m_s: the edge's velocity along itself, m/s, shape ``(..., 3)``.
        depth_m: the edge's depth below the material's surface, m, shape ``(...)``: picks
            the layer and the indentation ramp.

    The force is ``-P push_direction - S slice_direction`` (module docstring); zero where the
    edge does not advance (push speed <= :data:`ADVANCE_SPEED_M_S`).

    Example:
        >>> sawing = edge_force(CuttingParams(1000.0, slicing_efficiency=1.0), 0.04,
        ...                     (0.0, 0.0, -0.01), (0.0, 0.01, 0.0), 0.01)
        >>> round(float(sawing[2]), 3)  # 40 N / sqrt(2), up against the push
        28.284
    """
    push = np.asarray(push_velocity_m_s, dtype=float)
    slide = np.asarray(slice_velocity_m_s, dtype=float)
    push_speed = _norm(push)
    slice_speed = _norm(slide)
    advancing = push_speed > ADVANCE_SPEED_M_S
    safe_push = np.where(advancing, push_speed, 1.0)
    xi = np.where(advancing, slice_speed / safe_push, 0.0)
    resistance = (params.toughness_j_m2 * np.asarray(engaged_length_m, dtype=float)
                  * params.depth_factor(depth_m)
                  * params.rate_factor(np.hypot(push_speed, slice_speed)))
    resistance = np.where(advancing, resistance, 0.0)
    push_force = resistance * params.slicing_factor(xi)
    # S = G L (1 - 1/sqrt(1 + (eta xi)^2)) / xi, written so that xi -> 0 is not 0/0.
    root = np.sqrt(1.0 + (params.slicing_efficiency * xi) ** 2)
    slice_force = push_force * params.slicing_efficiency ** 2 * xi / (root + 1.0)
    push_direction = push / safe_push[..., None]
    slice_direction = slide / np.where(slice_speed > 0, slice_speed, 1.0)[..., None]
    return -(push_force[..., None] * push_direction + slice_force[..., None] * slice_direction)


def face_friction_force(params: CuttingParams, face_area_m2: ArrayLike,
                        push_velocity_m_s: ArrayLike, slice_velocity_m_s: ArrayLike,
                        wedged_area_m2: ArrayLike = 0.0, opening_strain: float = 0.0
                        ) -> np.ndarray:
    """The drag of the cut faces on the blade's two faces, N, shape ``(..., 3)``.

    Args:
        params: the cutting model (``face_friction`` and ``face_pressure_pa``).
        face_area_m2: area of one face of the blade inside the material, m^2, shape
            ``(...)``; both faces drag, so the force is ``2 mu p A``.
        push_velocity_m_s: the blade's velocity across its edge in its plane, m/s, ``(..., 3)``
            (negative push, moving back out, drags too).
        slice_velocity_m_s: the blade's velocity along its edge, m/s, ``(..., 3)``.
        wedged_area_m2: the blade's area in the material weighted by how far it opens the
            cut (the share of full opening), m^2, shape ``(...)``: the wedge's.
        opening_strain: the faces' strain at full opening, the blade's thickness over the
            block's extent across the blade (``t / W``).

    The force opposes the blade's velocity along its faces, its magnitude faded to zero below
    :data:`FRICTION_REGULARISATION_M_S`.

    Example:
        >>> params = CuttingParams(1000.0, face_friction=0.5, face_pressure_pa=2000.0)
        >>> face_friction_force(params, 1e-3, (0.0, 0.0, 0.01), (0.0, 0.0, 0.0)).tolist()
        [0.0, 0.0, -2.0]
    """
    velocity = (np.asarray(push_velocity_m_s, dtype=float)
                + np.asarray(slice_velocity_m_s, dtype=float))
    speed = _norm(velocity)
    scale = np.maximum(speed, FRICTION_REGULARISATION_M_S)
    drag = 2.0 * (params.face_friction * params.face_pressure_pa * np.asarray(
        face_area_m2, dtype=float) + params.face_modulus_pa * opening_strain
        * np.asarray(wedged_area_m2, dtype=float))
    return -(drag / scale)[..., None] * velocity


def push_and_slice(velocity_m_s: ArrayLike, edge_direction: ArrayLike,
                   blade_normal: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """The edge's velocity split into push (in the blade's plane, across the edge) and slice
    (along the edge); the part along the blade's normal belongs to neither.

    Example:
        >>> push, slide = push_and_slice((0.0, 0.02, -0.01), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
        >>> push.tolist(), slide.tolist()
        ([0.0, 0.0, -0.01], [0.0, 0.02, 0.0])
    """
    velocity = np.asarray(velocity_m_s, dtype=float)
    edge = np.asarray(edge_direction, dtype=float)
    normal = np.asarray(blade_normal, dtype=float)
    slide = (velocity @ edge)[..., None] * edge
    push = velocity - slide - (velocity @ normal)[..., None] * normal
    return push, slide


def path_velocity_m_s(time_s: ArrayLike, position_m: ArrayLike) -> np.ndarray:
    """(n, 3) the velocity along a logged path of positions (n, 3) at increasing times (n,),
    m/s: its derivative, second order on irregular samples (first with two samples).

    Example:
        >>> path_velocity_m_s([0.0, 0.5, 2.0], [[0, 0, 0], [0, 0, -0.005], [0, 0, -0.02]])[1]
        array([ 0.  ,  0.  , -0.01])
    """
    time = np.asarray(time_s, dtype=float)
    return np.gradient(np.asarray(position_m, dtype=float), time, axis=0,
                       edge_order=2 if len(time) > 2 else 1)


def beef_cutting() -> CuttingParams:
    """The cutting model of the default beef (``assets/materials/beef_default.toml``, whose
    comments give the sources and the derivations in full).

    The toughness is the geometric mean of the work of fracture through the perimysium of
    beef semitendinosus (Purslow 1985, Meat Science); the friction coefficient that of
    muscle on bone (Shacham, Castel & Gefen 2010, J. Biomech. Eng.); the slicing efficiency
    Atkins' ideal slice (Atkins, Xu & Jeronimidis 2004, J. Mater. Sci.); no rate dependence,
    as unfrozen beef cut at several feed speeds showed none (Brown, James & Purnell 2005,
    J. Food Eng.). The face pressure and the indentation depth are not published for meat:
    the transverse modulus times a closure strain of 0.1, and a guess of 2 mm.

    Example:
        >>> beef_cutting().toughness_j_m2
        850.0
    """
    return CuttingParams(toughness_j_m2=850.0, face_friction=0.3, face_pressure_pa=1600.0,
                         slicing_efficiency=1.0, reference_speed_m_s=0.01, rate_exponent=0.0,
                         indentation_depth_m=0.002)
