"""Dotted keys (``aponeurosis.stiffness_n_m``) applied to a scenario or to an env's keyword
arguments: how a sweep run differs from its base.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from cell.config import updated
from cell.errors import SweepError
from cell.sim.scenario import Scenario

#: The scenario file's ``[scenario]`` table holds the Scenario's own top-level fields.
_HEAD = "scenario."


def override_scenario(scenario: Scenario, values: Mapping[str, Any], *, file: Path,
                      section: str) -> Scenario:
    """``scenario`` with each dotted key of ``values`` replaced, checked as a scenario file's
    keys are (types, ranges); ``scenario.seed`` and the others of the ``[scenario]`` table
    name the top-level fields.

    Raises:
        SweepError: naming ``file`` and ``section.key``: an unknown key, a wrong type or a
            value out of range.

    Example:
        >>> base = Scenario()
        >>> changed = override_scenario(base, {"cut.speed_m_s": 0.05, "scenario.seed": 4},
        ...                             file=Path("s.toml"), section="variables")
        >>> changed.cut.speed_m_s, changed.seed, changed.cut.depth_m == base.cut.depth_m
        (0.05, 4, True)
        >>> override_scenario(base, {"cut.speed": 0.05}, file=Path("s.toml"),
        ...                   section="variables")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        cell.errors.SweepError: s.toml, variables.cut.speed: unknown key (known keys: ...)
    """
    for key, value in values.items():
        parts = key.removeprefix(_HEAD).split(".")
        scenario = _replaced(scenario, parts, value, file, f"{section}.{key}")
    return scenario


def _replaced(instance: Any, parts: list[str], value: Any, file: Path, where: str) -> Any:
    """``instance`` with the field at path ``parts`` set to ``value``."""
    head = where.removesuffix("." + ".".join(parts))
    if len(parts) == 1:
        return updated(instance, {parts[0]: value}, file=file, section=head, error=SweepError)
    names = [f.name for f in dataclasses.fields(instance) if f.init]
    child = getattr(instance, parts[0], None) if parts[0] in names else None
    if child is None or not dataclasses.is_dataclass(child):
        known = ", ".join(n for n in names
                          if dataclasses.is_dataclass(getattr(instance, n, None)))
        raise SweepError(file, f"{head}.{parts[0]}", f"not a table of the scenario "
                         f"(tables: {known or 'none'})")
    inner = _replaced(child, parts[1:], value, file, where)
    return dataclasses.replace(instance, **{parts[0]: inner})


def nested(values: Mapping[str, Any]) -> dict[str, Any]:
    """Dotted keys unfolded into nested dicts, as an env's keyword arguments take them.

    Example:
        >>> nested({"cell_size_m": 0.05, "reward.cut_weight": 2.0, "reward.tear": 1.0})
        {'cell_size_m': 0.05, 'reward': {'cut_weight': 2.0, 'tear': 1.0}}
    """
    tree: dict[str, Any] = {}
    for key, value in values.items():
        *path, last = key.split(".")
        node = tree
        for part in path:
            node = node.setdefault(part, {})
        node[last] = value
    return tree
