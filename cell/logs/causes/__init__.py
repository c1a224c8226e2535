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

from importlib import import_module
from typing import Any

from cell.errors import LogError
from cell.logs.causes.cause import MAX_MAGNITUDE, LogCause
from cell.sim.scenario import Scenario

__all__ = ["CAUSES", "MAX_MAGNITUDE", "REGISTERED", "SENSOR_OFFSET", "LogCause", "applicable",
           "changed_world", "magnitudes_json", "table_causes"]

#: The registry: the modules of this package that hold a cause (its ``CAUSE``), in the order
#: the diagnosis screens them. A new cause is one module and one line here.
REGISTERED = (
    "binding_strength",
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


def magnitudes_json(magnitudes: dict[str, float]) -> dict[str, dict[str, Any]]:
    """Each cause's magnitude as a user reads it (:meth:`LogCause.to_json`)."""
    return {name: CAUSES[name].to_json(m) for name, m in magnitudes.items()}
