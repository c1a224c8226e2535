"""The cutting model's terms with a state along the edge's path: the loading before the crack
runs and the friction of the material along the edge (:mod:`cell.tissue.cutmodel`'s module
docstring gives the physics). The reduced model of a cut test and the full simulation's edge
term both apply :func:`loaded_edge_force`, on strips of material along the edge or on one.

Example:
    >>> edge_friction_state([0.0, 0.01, 0.0], [2.0, 2.0, 2.0], 0.001).round(3)
    array([ 0., -2.,  2.])
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from cell.tissue.cutmodel import ADVANCE_SPEED_M_S, CuttingParams, edge_force


def _norm(vectors: np.ndarray) -> np.ndarray:
    return np.sqrt(np.einsum("...i,...i->...", vectors, vectors))


def loaded_share(depth_m: np.ndarray, inside: np.ndarray, loading_depth_m: float,
                 push_factor: np.ndarray) -> np.ndarray:
    """(n, s) the edge's load, as a share of ``G`` per unit length, in each strip of material
    along it (module docstring, loading before the crack runs).

    Args:
        depth_m: (n, s) the edge's depth below the surface in each strip, per sample, m.
        inside: (n, s) whether the edge is in the material there.
        loading_depth_m: the depth sunk past the front at which the crack runs, m, > 0.
        push_factor: (n,) the load the crack needs, as a share of ``G`` (the slicing factor).

    The crack front of a strip is the deepest ``depth - loading_depth_m * push_factor`` the
    edge has reached in it (never above the surface); the share is the depth past it over
    ``loading_depth_m``.

    Example:
        >>> depth = np.array([[0.001], [0.004], [0.003], [0.005]])
        >>> loaded_share(depth, depth > 0, 0.002, np.ones(4)).ravel().round(3).tolist()
        [0.5, 1.0, 0.5, 1.0]
    """
    reach = np.where(inside, depth_m - loading_depth_m * np.asarray(push_factor)[:, None],
                     0.0)
    front = np.maximum.accumulate(np.maximum(reach, 0.0), axis=0)
    return np.where(inside, np.clip((depth_m - front) / loading_depth_m, 0.0, 1.0), 0.0)


def edge_friction_state(along_m: ArrayLike, load_n: ArrayLike, slip_m: float) -> np.ndarray:
    """(n,) the Dahl friction of the material on the edge along itself per unit of
    ``edge_friction``, N, positive along the edge: the edge at ``along_m`` (n,; m, its
    position along itself) under the load ``load_n`` (n,; N). Each step of the edge by du
    moves the force towards ``-sign(du) load`` by the share ``1 - exp(-|du| / slip_m)``.

    Example:
        >>> edge_friction_state([0.0, 0.001, 0.01, 0.01, 0.0], [1.0] * 5, 0.001).round(3)
        array([ 0.   , -0.632, -1.   , -1.   ,  1.   ])
    """
    along = np.asarray(along_m, dtype=float)
    load = np.asarray(load_n, dtype=float)
    step = np.diff(along, prepend=along[:1])
    keep = np.exp(-np.abs(step) / slip_m)
    target = -np.sign(step) * load
    state = np.zeros(len(along))
    for k in range(1, len(along)):
        state[k] = target[k] + (state[k - 1] - target[k]) * keep[k]
    return state


@dataclass(frozen=True, eq=False)
class EdgeState:
    """Where an edge is along a path, for the terms with a state (:func:`loaded_edge_force`):
    per sample (n) and strip of material along the edge (s).

    Attributes:
        length_m: (n, s) each strip's length of edge, weighted by its depth factor, m.
        depth_m: (n, s) the edge's depth below the surface in each strip, m.
        inside: (n, s) whether the edge is in the material in the strip.
        fresh: (n, s) whether it cuts fresh material there.
        push_m_s, slice_m_s: (n, 3) the edge's push and slice velocities, m/s.
        along_m: (n,) the edge's midpoint along the edge direction, m.
        down: (3,) the cutting direction; edge: (3,) the edge's direction.
        middle_depth_m: (n,) the midpoint's depth below the top, m.
    """

    length_m: np.ndarray
    depth_m: np.ndarray
    inside: np.ndarray
    fresh: np.ndarray
    push_m_s: np.ndarray
    slice_m_s: np.ndarray
    along_m: np.ndarray
    down: np.ndarray
    edge: np.ndarray
    middle_depth_m: np.ndarray


def loaded_edge_force(params: CuttingParams, state: EdgeState) -> np.ndarray:
    """(n, 3) the edge's force along a path with the loading before the crack runs and the
    friction along the edge (module docstring), N: :func:`edge_terms` joined.

    Example:
        >>> depth = np.array([[-0.001], [0.001], [0.002], [0.002]])
        >>> push = np.array([[0.0, 0.0, -0.001]] * 3 + [[0.0, 0.0, 0.0]])
        >>> state = EdgeState(np.full((4, 1), 0.04), depth, depth > 0, depth > 0, push,
        ...                   np.zeros((4, 3)), np.zeros(4), np.array([0.0, 0.0, -1.0]),
        ...                   np.array([0.0, 1.0, 0.0]), depth[:, 0])
        >>> params = CuttingParams(1000.0, loading_depth_m=0.002)
        >>> (loaded_edge_force(params, state)[:, 2] + 0.0).tolist()  # ramps in, holds
        [0.0, 20.0, 40.0, 40.0]
    """
    force, rubbing = edge_terms(params, state, params.edge_friction > 0.0)
    return force + params.edge_friction * rubbing


def edge_terms(params: CuttingParams, state: EdgeState, rubbing: bool = True
               ) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) the edge's force without its friction along itself, N, and (n, 3) that friction
    per unit of ``edge_friction`` (zero unless ``rubbing``), N: the load presses against the
    cutting direction; where the edge cuts fresh material the slice component of
    :func:`~cell.tissue.cutmodel.edge_force` goes with it in the law's ratio to the push.
    Layers and the indentation ramp come in through ``state.length_m``; the rate factor
    here."""
    uniform = params.uniform()
    if params.loading_depth_m > 0.0:
        unit = edge_force(replace(uniform, toughness_j_m2=1.0), np.ones(len(state.along_m)),
                          state.push_m_s, state.slice_m_s, state.middle_depth_m)
        advancing = state.push_m_s @ state.down > ADVANCE_SPEED_M_S
        push_share = np.where(advancing, np.maximum(-(unit @ state.down), 1e-12), 1.0)
        share = loaded_share(state.depth_m, state.inside, params.loading_depth_m, push_share)
        load = uniform.rate_factor(_norm(state.push_m_s + state.slice_m_s)) * (
            uniform.toughness_j_m2 * (state.length_m * share).sum(axis=1))
        along = unit - (unit @ state.down)[:, None] * state.down
        cutting = (advancing & state.fresh.any(axis=1))[:, None]
        force = -load[:, None] * state.down + np.where(
            cutting, along * (load / push_share)[:, None], 0.0)
    else:
        force = edge_force(uniform, np.where(state.fresh, state.length_m, 0.0).sum(axis=1),
                           state.push_m_s, state.slice_m_s, state.middle_depth_m)
    if not rubbing:
        return force, np.zeros_like(force)
    load_n = np.maximum(-(force @ state.down), 0.0)
    return force, edge_friction_state(state.along_m, load_n, params.edge_slip_m)[:, None] * (
        state.edge)
