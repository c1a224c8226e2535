"""The causes a batch of separation logs can show (the log cause table of docs/logs.md,
and the causes of the cut cause table, docs/measured-data.md, that map onto the cell's
knife), each a change of the world the replay applies with one magnitude.

A magnitude of 0 is the world as the lab believes it. Factors are carried as their natural
logarithm (a magnitude ``m`` means a factor ``exp(m)``), so that a change and its inverse are
as far from the belief and a factor can never turn negative:

=====================  ==========================================================================
``binding_strength``   the seam's toughness and the bindings' stiffness times ``exp(m)``
``binding_gradient``   the seam's toughness times ``exp(m (x - x_mid) / L)`` along the
                       interface (``L`` its length): ``exp(m)`` is the ratio of its two ends
``tearing_threshold``  the bindings' tearing stretch (and tearing force) times ``exp(m)``
``tissue_stiffness``   the material's moduli times ``exp(m)``
``fibre_direction``    the fibres turned about the vertical by ``m`` rad
``blade_friction``     the material's face friction (its ``[cutting]`` table) times ``exp(m)``
=====================  ==========================================================================

``sensor_offset`` is no change of the world: it is fitted on the logged channels in closed
form (:mod:`cell.logs.fit`), without a replay.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from cell.diagnosis.engine.determined import NOT_IN_LOGS, determined
from cell.errors import LogError
from cell.sim.scenario import Scenario
from cell.tissue.material import ContinuumMaterial, MassSpringMaterial

if TYPE_CHECKING:
    from cell.sim.episode import Episode

_CURVES = ("longitudinal", "transverse", "longitudinal_compression", "transverse_compression")


@dataclass(frozen=True)
class LogCause:
    """One cause of the catalogue.

    Attributes:
        name: its name in the cause tables (docs/logs.md, docs/measured-data.md).
        step: the magnitude of its screening replay (log factor, or rad).
        kind: ``"factor"`` (the magnitude is a log factor) or ``"angle"`` (rad).

    Example:
        >>> CAUSES["tissue_stiffness"].value(0.0)
        1.0
    """

    name: str
    step: float
    kind: str = "factor"

    def value(self, magnitude: float) -> float:
        """What a user reads: the factor ``exp(m)`` (infinite past a float's range), or the
        angle in rad."""
        if self.kind != "factor":
            return magnitude
        return math.exp(magnitude) if magnitude < _LARGEST_LOG else math.inf


#: The natural log of the largest float: ``math.exp`` of more raises.
_LARGEST_LOG = math.log(sys.float_info.max)
#: The world causes, in the order the diagnosis screens them.
CAUSES = {cause.name: cause for cause in (
    LogCause("binding_strength", 0.4), LogCause("binding_gradient", 0.6),
    LogCause("tearing_threshold", 0.4), LogCause("tissue_stiffness", 0.3),
    LogCause("fibre_direction", 0.6, "angle"), LogCause("blade_friction", 0.7))}
#: The cause fitted on the channels alone.
SENSOR_OFFSET = "sensor_offset"


def applicable(scenario: Scenario) -> tuple[str, ...]:
    """The causes that change something in ``scenario``'s world (``blade_friction`` needs a
    cutting model with face friction, ``binding_gradient`` the cutting model's seam,
    ``fibre_direction`` a mass-spring material)."""
    cutting = scenario.aponeurosis.knife_force == "cutting"
    friction = scenario.material.cutting is not None and scenario.material.cutting.face_friction
    needs = {"binding_gradient": cutting, "blade_friction": cutting and bool(friction),
             "fibre_direction": isinstance(scenario.material, MassSpringMaterial)}
    return tuple(name for name in CAUSES if needs.get(name, True))


def changed_world(scenario: Scenario, magnitudes: dict[str, float]) -> Scenario:
    """``scenario`` with the causes of ``magnitudes`` applied (``binding_gradient`` is not a
    key of a scenario: :func:`episode_adjustment` applies it).

    Raises:
        LogError: an unknown cause.

    Example:
        >>> world = changed_world(Scenario(), {"tearing_threshold": math.log(2.0)})
        >>> round(world.aponeurosis.tearing_stretch_m, 6)
        0.02
    """
    unknown = sorted(set(magnitudes) - set(CAUSES))
    if unknown:
        raise LogError(None, "causes", f"unknown cause {unknown[0]!r}; known: {list(CAUSES)}")
    apo, material = scenario.aponeurosis, scenario.material
    factor = {name: math.exp(m) for name, m in magnitudes.items()}
    if "binding_strength" in magnitudes:
        f = factor["binding_strength"]
        apo = replace(apo, toughness_j_m2=apo.toughness_j_m2 * f,
                      stiffness_n_m=apo.stiffness_n_m * f)
    if "tearing_threshold" in magnitudes:
        f = factor["tearing_threshold"]
        apo = replace(apo, tearing_stretch_m=apo.tearing_stretch_m * f,
                      tearing_force_n=apo.tearing_force_n * f)
    if "tissue_stiffness" in magnitudes:
        material = _stiffer(material, factor["tissue_stiffness"])
    if "fibre_direction" in magnitudes and isinstance(material, MassSpringMaterial):
        angle = magnitudes["fibre_direction"]
        turn = np.array([[math.cos(angle), -math.sin(angle), 0.0],
                         [math.sin(angle), math.cos(angle), 0.0], [0.0, 0.0, 1.0]])
        material = replace(material, fibre_direction=tuple(
            (turn @ np.asarray(material.fibre_direction)).tolist()))
    if "blade_friction" in magnitudes and material.cutting is not None:
        cutting = material.cutting
        material = replace(material, cutting=replace(
            cutting, face_friction=cutting.face_friction * factor["blade_friction"]))
    return replace(scenario, aponeurosis=apo, material=material)


def _stiffer(material: Any, factor: float) -> Any:
    if isinstance(material, ContinuumMaterial):
        return replace(material, young_pa=material.young_pa * factor)
    curves = {name: replace(curve, coefficients=tuple(c * factor for c in curve.coefficients))
              for name in _CURVES if (curve := getattr(material, name)) is not None}
    return replace(material, **curves)


def episode_adjustment(magnitudes: dict[str, float]) -> Callable[[Episode], None] | None:
    """What the replay applies to the built episode: the seam's toughness graded along the
    interface (``binding_gradient``), or None."""
    slope = magnitudes.get("binding_gradient", 0.0)
    if not slope:
        return None

    def grade(episode: Episode) -> None:
        if episode.sim.seam is not None:
            top = np.asarray(episode.scene.mesh.top_line, dtype=float)
            episode.sim.seam = GradedSeam(episode.sim.seam, slope, float(top[0, 0]),
                                          float(top[-1, 0]))

    return grade


class GradedSeam:
    """A seam (:class:`~cell.tissue.seamcut.SeamCut`) whose toughness changes along the
    interface: its edge's force and resistance times ``exp(slope (x - x_mid) / L)`` at the
    blade's centre ``x`` (m), ``L`` the interface's length from ``start_m`` to ``end_m``.

    Example:
        >>> class Flat:
        ...     def reset(self): return "reset"
        >>> GradedSeam(Flat(), 0.5, 0.0, 0.3).reset()
        'reset'
    """

    def __init__(self, seam: Any, slope: float, start_m: float, end_m: float) -> None:
        self._seam, self._slope = seam, slope
        self._mid, self._length = 0.5 * (start_m + end_m), max(abs(end_m - start_m), 1e-6)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._seam, name)

    def load(self, blade_pos: np.ndarray, blade_mat: np.ndarray, half_size_m: np.ndarray,
             velocity_m_s: np.ndarray) -> Any:
        """The seam's load with the edge's part graded (the faces' friction unchanged)."""
        load = self._seam.load(blade_pos, blade_mat, half_size_m, velocity_m_s)
        factor = math.exp(self._slope * (float(blade_pos[0]) - self._mid) / self._length)
        return replace(load, edge_n=load.edge_n * factor,
                       resistance_n=load.resistance_n * factor)


def magnitudes_json(magnitudes: dict[str, float]) -> dict[str, dict[str, float]]:
    """Each cause's magnitude as a user reads it: ``factor`` (or ``angle_deg``) beside the
    fitted ``magnitude``; one the logs do not determine ``null`` with its reason
    (:mod:`cell.diagnosis.engine.determined`)."""
    out = {}
    for name, m in magnitudes.items():
        cause = CAUSES[name]
        shown = (determined("factor", cause.value(m), NOT_IN_LOGS) if cause.kind == "factor"
                 else determined("angle_deg", math.degrees(m), NOT_IN_LOGS))
        out[name] = {**determined("magnitude", m, NOT_IN_LOGS), **shown}
    return out

