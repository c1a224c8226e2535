"""Scenario files written from another scenario file's tables: the files it names by their
resolved paths (the written scenario lies elsewhere), and the tables as TOML text. The
hidden-effect log batches write their logs' scenarios with it, the batch diagnosis its
extended scenario.
"""

from __future__ import annotations

import json
from typing import Any

from cell.sim.scenario import Scenario

#: The keys of a scenario that name files (relative to the scenario): table -> key -> the
#: loaded scenario's part that holds it resolved.
FILE_KEYS = {"aponeurosis": {"force_curve": lambda s: s.aponeurosis.force_curve},
             "tissue": {"surface_mesh": lambda s: list(s.tissue.surface_mesh)},
             "knife": {"handle_mesh": lambda s: s.knife.handle_mesh},
             "fixture": {"clamp_mesh": lambda s: s.fixture.clamp_mesh}}


def resolved_tables(raw: dict[str, Any], scenario: Scenario) -> dict[str, Any]:
    """A scenario file's tables (``raw``) but its material, the files it names by their
    resolved paths (from ``scenario``, the file loaded)."""
    tables = {name: dict(table) for name, table in raw.items() if name != "material"}
    for name, keys in FILE_KEYS.items():
        for key, resolved in keys.items():
            if key in tables.get(name, {}):
                tables[name][key] = resolved(scenario)
    for place, choice in tables.get("arms", {}).items():  # [arms.<place>] file = ...
        if isinstance(choice, dict) and "file" in choice:
            tables["arms"][place] = {**choice, "file": getattr(scenario.arms, place).file}
    return tables


def tables_toml(tables: dict[str, dict[str, Any]], header: str) -> str:
    """``tables`` as the text of a TOML file, ``header``'s lines as comments on top.

    Example:
        >>> print(tables_toml({"scenario": {"name": "x", "seed": 3}}, "made here"), end="")
        # made here
        <BLANKLINE>
        [scenario]
        name = "x"
        seed = 3
    """
    lines = [f"# {line}" for line in header.splitlines()]
    for name, table in tables.items():
        lines += ["", f"[{name}]"]
        lines += [f"{key} = {toml_value(value)}" for key, value in table.items()]
    return "\n".join(lines) + "\n"


def toml_value(value: Any) -> str:
    """One TOML value: a boolean, number, text, list or inline table.

    Raises:
        TypeError: a value TOML has no form for.
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"no TOML for {value!r}")
