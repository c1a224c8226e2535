"""The causes a batch of separation logs can show (the log cause table of docs/logs.md, and
the causes of the cut cause table, docs/measured-data.md, that map onto the cell's knife):
one module each, an object of a :class:`~cell.logs.causes.cause.LogCause` subclass, registered
below. Adding a cause is one new module and one line in :data:`REGISTERED` (docs/logs.md): the
diagnosis screens it, the report writes its change into the extended scenario, the
hidden-effect batches can hide it and the bench cycles through it.

=====================  ===================================================================
``binding_strength``   the seam's toughness and the bindings' stiffness times ``exp(m)``
``binding_gradient``   the seam's toughness times ``exp(m (x - x_mid) / L)`` along the
                       interface (``L`` its length): ``exp(m)`` is the ratio of its two ends
``tearing_threshold``  the bindings' tearing stretch (and tearing force) times ``exp(m)``
``tissue_stiffness``   the material's moduli times ``exp(m)``
``fibre_direction``    the fibres turned about the vertical by ``m`` rad
``blade_friction``     the material's face friction (its ``[cutting]`` table) times ``exp(m)``
=====================  ===================================================================

``sensor_offset`` is no change of the world: it is fitted on the logged channels in closed
form (:mod:`cell.logs.fit`), without a replay.
"""

from __future__ import annotations

from dataclasses import fields, is_dataclass
from importlib import import_module
from typing import Any

import numpy as np

from cell.errors import LogError
from cell.logs.causes.cause import MAX_MAGNITUDE, LogCause
from cell.sim.scenario import Scenario

__all__ = ["CAUSES", "MAX_MAGNITUDE", "REGISTERED", "SENSOR_OFFSET", "LogCause", "applicable",
           "changed_world", "magnitudes_json", "table_causes"]

#: The registry: the modules of this package that hold a cause (its ``CAUSE``), in the order
#: the diagnosis screens them. A new cause is one module and one line here.
REGISTERED = (
    "binding_strength",
    "binding_stiffness",
    "binding_gradient",
    "tearing_threshold",
    "tissue_stiffness",
    "fibre_direction",
    "blade_friction",
)
#: The world causes by name, in the registry's order.
CAUSES: dict[str, LogCause] = {
    cause.name: cause for cause in (import_module(f"{__name__}.{module}").CAUSE
                                    for module in REGISTERED)}
#: The cause fitted on the channels alone.
SENSOR_OFFSET = "sensor_offset"


def applicable(scenario: Scenario) -> tuple[str, ...]:
    """The causes that change something in ``scenario``'s world (:meth:`LogCause.applies`)."""
    return tuple(name for name, cause in CAUSES.items() if cause.applies(scenario))


def table_causes(table: str = "logs") -> tuple[str, ...]:
    """The world causes of a cause table (:attr:`LogCause.table`) and, for the log table,
    ``sensor_offset``: what the bench cycles through."""
    world = tuple(name for name, cause in CAUSES.items() if cause.table == table)
    return (*world, SENSOR_OFFSET) if table == "logs" else world


def changed_world(scenario: Scenario, magnitudes: dict[str, float]) -> Scenario:
    """``scenario`` with the causes of ``magnitudes`` applied (:meth:`LogCause.change`).

    Raises:
        LogError: an unknown cause.

    Example:
        >>> import math
        >>> world = changed_world(Scenario(), {"tearing_threshold": math.log(2.0)})
        >>> round(world.aponeurosis.tearing_stretch_m, 6)
        0.02
    """
    unknown = sorted(set(magnitudes) - set(CAUSES))
    if unknown:
        raise LogError(None, "causes", f"unknown cause {unknown[0]!r}; known: {list(CAUSES)}")
    for name, magnitude in magnitudes.items():
        scenario = CAUSES[name].change(scenario, magnitude)
    return scenario


def changed_keys(belief: Scenario, world: Scenario) -> dict[str, dict[str, Any]]:
    """The scenario's tables (but the material, a file of its own) and their keys whose values
    differ in ``world`` from ``belief``: what a cause's change of the world writes into the
    extended scenario.

    Example:
        >>> from dataclasses import replace
        >>> belief = Scenario()
        >>> world = replace(belief, aponeurosis=replace(belief.aponeurosis,
        ...                                             toughness_gradient=0.5))
        >>> changed_keys(belief, world)
        {'aponeurosis': {'toughness_gradient': 0.5}}
    """
    out: dict[str, dict[str, Any]] = {}
    for table in fields(belief):
        before, after = getattr(belief, table.name), getattr(world, table.name)
        if table.name == "material" or not is_dataclass(before) or before == after:
            continue
        out[table.name] = {key.name: getattr(after, key.name) for key in fields(before)
                           if getattr(after, key.name) != getattr(before, key.name)}
    return out


def scenario_keys(name: str, scenario: Scenario) -> tuple[str, ...]:
    """The dotted keys cause ``name`` changes in ``scenario``'s world (at its screening
    step): a scenario table's keys, or ``material.<key>`` for the material file's.

    Example:
        >>> scenario_keys("blade_friction", Scenario())
        ('material.cutting.face_friction',)
    """
    cause = CAUSES[name]
    world = cause.change(scenario, cause.step)
    return tuple(sorted(key for table in fields(scenario) for key in _changed_fields(
        table.name, getattr(scenario, table.name), getattr(world, table.name))))


def _changed_fields(prefix: str, before: Any, after: Any) -> list[str]:
    """The dotted names of the fields of two like dataclasses that differ, nested ones
    spelt down to their own fields."""
    if before == after:
        return []
    if type(before) is not type(after) or not is_dataclass(before):
        return [prefix]
    return [name for item in fields(before) for name in _changed_fields(
        f"{prefix}.{item.name}", getattr(before, item.name), getattr(after, item.name))]


def magnitudes_json(magnitudes: dict[str, float]) -> dict[str, dict[str, Any]]:
    """Each cause's magnitude as a user reads it (:meth:`LogCause.to_json`)."""
    return {name: CAUSES[name].to_json(m) for name, m in magnitudes.items()}


def bounded(world: list[str], magnitudes: np.ndarray) -> np.ndarray:
    """``magnitudes`` of ``world``'s causes within each cause's bounds
    (:attr:`~cell.logs.causes.cause.LogCause.bounds`: beyond them the cell is another cell,
    and its physics may not hold)."""
    low, high = np.array([CAUSES[c].bounds for c in world], dtype=float).reshape(-1, 2).T
    return np.clip(magnitudes, low, high)
