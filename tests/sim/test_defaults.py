"""One set of defaults: the code's parameter defaults are the default scenario's values, so a
scenario that gives only its meat runs the cell of ``scenarios/default.toml``."""

from __future__ import annotations

import tomllib
from dataclasses import fields, is_dataclass
from pathlib import Path

from cell.sim.scenario import load_scenario
from tests.paths import DEFAULT_SCENARIO


def _differences(file_value: object, code_value: object, key: str = "") -> list[str]:
    """The dotted keys at which two scenarios (or parts of them) differ."""
    if is_dataclass(file_value) and type(file_value) is type(code_value):
        return [difference for item in fields(file_value)
                for difference in _differences(getattr(file_value, item.name),
                                               getattr(code_value, item.name),
                                               f"{key}.{item.name}".lstrip("."))]
    if file_value != code_value:
        return [f"{key}: default.toml {file_value!r}, code {code_value!r}"]
    return []


def test_a_tissue_only_scenario_loads_equal_to_the_default(tmp_path: Path) -> None:
    tissue = tomllib.loads(Path(DEFAULT_SCENARIO).read_text())["tissue"]
    minimal = tmp_path / "tissue_only.toml"
    minimal.write_text("[tissue]\n" + "".join(f"{key} = {value!r}\n"
                                              for key, value in tissue.items()))
    default = load_scenario(DEFAULT_SCENARIO)
    loaded = load_scenario(minimal)
    assert loaded == default, _differences(default, loaded)
