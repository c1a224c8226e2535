"""What a cause of the log diagnosis is (docs/logs.md, "Adding a cause"): a change of the
world, the scenario a log ran, with one magnitude. Each cause is an object of a subclass of
:class:`LogCause`, in a module of its own in this package, registered in its ``__init__``.

A magnitude of 0 is the world as the lab believes it. Factors are carried as their natural
logarithm (a magnitude ``m`` means a factor ``exp(m)``), so that a change and its inverse are
as far from the belief and a factor can never turn negative.
"""

from __future__ import annotations

import math
import sys
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, Literal

from cell.diagnosis.engine.determined import NOT_IN_LOGS, determined
from cell.sim.scenario import Scenario

#: The largest magnitude the fit moves a cause to (a factor of ``exp(1.5)``, about 4.5, or
#: 1.5 rad): the default of :attr:`LogCause.bounds`.
MAX_MAGNITUDE = 1.5
#: The share of each bound a wide probe reaches (:meth:`LogCause.probes`): a factor of about
#: 2.5 or 0.4 at the default bounds, where a threshold halved or a stiffness 2.5x shows as it
#: is, not as a small step's slope.
WIDE_SHARE = 0.6
#: The natural log of the largest float: ``math.exp`` of more raises.
_LARGEST_LOG = math.log(sys.float_info.max)


@dataclass(frozen=True)
class LogCause(ABC):
    """One cause of the catalogue: a subclass says how it changes the world
    (:meth:`change`) and where it can (:meth:`applies`).

    Attributes:
        name: its name in the cause tables (docs/logs.md, docs/measured-data.md).
        step: the magnitude of its screening probe: the replays one way and the other that
            give its signature (log factor, or rad).
        kind: ``"factor"`` (the magnitude is a log factor) or ``"angle"`` (rad).
        table: the cause table that describes it: ``"logs"`` (docs/logs.md; benched by
            ``bench diagnose --logs``) or ``"cut"`` (docs/measured-data.md; benched by
            ``--cut``).
        typical: the size of change the table calls typical, for the hidden-effect
            batches: a factor's range (away from 1, either way), or an angle's, degrees.
        bounds: the magnitudes the fit may move it to (log factor, or rad).

    Example:
        >>> from cell.logs.causes import CAUSES
        >>> CAUSES["tissue_stiffness"].value(0.0)
        1.0
    """

    name: str
    step: float
    kind: Literal["factor", "angle"] = "factor"
    table: Literal["logs", "cut"] = "logs"
    typical: tuple[float, float] = (1.3, 2.0)
    bounds: tuple[float, float] = (-MAX_MAGNITUDE, MAX_MAGNITUDE)

    def probes(self, wide: bool) -> tuple[float, ...]:
        """The magnitudes its screening replays: its :attr:`step` one way and the other, and,
        ``wide``, :data:`WIDE_SHARE` of each bound (where that is beyond the step)."""
        small = (self.step, -self.step)
        if not wide:
            return small
        far = tuple(WIDE_SHARE * b for b in (self.bounds[1], self.bounds[0])
                    if abs(WIDE_SHARE * b) > self.step)
        return small + far

    def applies(self, scenario: Scenario) -> bool:
        """Whether the cause changes anything in ``scenario``'s world (every world: True)."""
        return True

    @abstractmethod
    def change(self, scenario: Scenario, magnitude: float) -> Scenario:
        """``scenario`` with the cause at ``magnitude``: every subclass says how."""

    def value(self, magnitude: float) -> float:
        """What a user reads: the factor ``exp(m)`` (infinite past a float's range), or the
        angle in rad."""
        if self.kind != "factor":
            return magnitude
        return math.exp(magnitude) if magnitude < _LARGEST_LOG else math.inf

    def to_json(self, magnitude: float) -> dict[str, Any]:
        """The fitted ``magnitude`` beside its ``factor`` (or ``angle_deg``); one the logs do
        not determine ``null`` with its reason (:mod:`cell.diagnosis.engine.determined`)."""
        shown = (determined("factor", self.value(magnitude), NOT_IN_LOGS)
                 if self.kind == "factor"
                 else determined("angle_deg", math.degrees(magnitude), NOT_IN_LOGS))
        return {**determined("magnitude", magnitude, NOT_IN_LOGS), **shown}
