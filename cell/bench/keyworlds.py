"""Separation-log batches from worlds changed the way a user changes one: by editing keys of
the scenario file and of the material file it names, read back by the project's own readers,
not through the log diagnosis's cause code (:mod:`cell.synthetic.logs` applies the causes'
own changes). A bench on these batches checks that what the diagnosis names is what a user
changed, at the size it was changed.

Each hidden change edits the keys one log cause maps to
(:func:`~cell.logs.causes.scenario_keys`, the table of docs/logs.md) by one drawn size: a factor
on a number (every number of a list), the natural log of the factor added to
``aponeurosis.toughness_gradient`` (the ratio of the seam's toughness at its two ends), an angle
about the vertical for ``material.fibre_direction``. Factors are drawn from 0.4 to 2.5, either
way, half of them beyond 0.6 or 1.8 (:func:`draw_size`). Each log's meat is a shape drawn from
the documented shape ranges (:func:`~cell.bench.shapes.documented_shape`), its episode seed its
own.

Example:
    >>> import tempfile
    >>> from pathlib import Path
    >>> folder = Path(tempfile.mkdtemp()) / "batch"
    >>> truth = write_key_change_batch(folder, seed=1, base="scenarios/quick.toml",
    ...                                causes=("tearing_threshold",), logs=1, end_s=0.04)
    >>> truth.causes, round(truth.magnitudes["tearing_threshold"], 3) > 0
    (('tearing_threshold',), True)
"""

from __future__ import annotations

import math
import tempfile
import time
import tomllib
from collections.abc import Sequence
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from cell.bench.shapes import documented_shape
from cell.config import read_toml
from cell.errors import LogError
from cell.logs.causes import CAUSES, scenario_keys
from cell.outputs import write_atomic
from cell.sim.episodelog import LoggedEpisode, write_log
from cell.sim.scenario import Scenario, load_scenario
from cell.sim.scenariotoml import resolved_tables, tables_toml
from cell.synthetic.logs import LOG_COUNT, LogBatchTruth, log_scenario_toml
from cell.tissue.material import MassSpringMaterial
from cell.tissue.materialfile import material_from_table, material_to_toml

#: The factors drawn: from 1 / ``FACTOR_RANGE[1]`` to ``FACTOR_RANGE[1]``, never nearer 1
#: than ``FACTOR_RANGE[0]`` (a smaller change the logs cannot be asked to show).
FACTOR_RANGE = (1.25, 2.5)
#: A large change: beyond this factor (or below its inverse); half the draws are large.
LARGE_FACTOR = 1.8
#: The key whose edit adds the log of the factor (a log-ratio, 0 in the default world).
RATIO_KEYS = ("aponeurosis.toughness_gradient",)
#: The key whose edit turns a direction about the vertical by an angle.
ANGLE_KEYS = ("material.fibre_direction",)
_HEADER = ("Separation log (musclecell, cell/bench/keyworlds.py): the cell as the lab "
           "believes it,\nthis log's meat shape; a world with edited keys ran it.")


def draw_size(cause: str, rng: np.random.Generator) -> float:
    """The size of a hidden change of ``cause``: a factor (half of them large, either way), or
    for a cause of kind ``"angle"`` an angle in rad within its ``typical`` degrees."""
    sign = float(rng.choice([-1.0, 1.0]))
    if CAUSES[cause].kind == "angle":
        low, high = CAUSES[cause].typical
        return sign * math.radians(float(rng.uniform(low, high)))
    low, high = ((LARGE_FACTOR, FACTOR_RANGE[1]) if rng.random() < 0.5
                 else (FACTOR_RANGE[0], LARGE_FACTOR))
    return math.exp(sign * float(rng.uniform(math.log(low), math.log(high))))


def edited(key: str, value: Any, size: float) -> Any:
    """``value`` of dotted ``key`` after the edit of ``size`` (module docstring)."""
    if key in ANGLE_KEYS:
        x, y, z = (float(v) for v in value)
        c, s = math.cos(size), math.sin(size)
        return [c * x - s * y, s * x + c * y, z]
    if key in RATIO_KEYS:
        return float(value) + math.log(size)
    if isinstance(value, list | tuple):
        return [float(v) * size for v in value]
    return float(value) * size


def _set(table: dict[str, Any], path: Sequence[str], size: float, key: str) -> None:
    *parents, name = path
    for part in parents:
        table = table.setdefault(part, {})
    table[name] = edited(key, table[name], size)


def cause_edits(base: Scenario, sizes: dict[str, float]) -> dict[str, float]:
    """The key edits of causes (cause -> size): each key the cause maps to, its size; a key
    two causes map to (``binding_strength`` and ``binding_stiffness`` both scale the bindings'
    stiffness) edited by both, as the causes' own changes compose (factors multiply, angles
    add)."""
    edits: dict[str, float] = {}
    for cause, size in sizes.items():
        for key in scenario_keys(cause, base):
            if key not in edits:
                edits[key] = size
            else:
                edits[key] = edits[key] + size if key in ANGLE_KEYS else edits[key] * size
    return edits


def world_files(folder: Path, base: Scenario, tables: dict[str, Any],
                edits: dict[str, float]) -> Path:
    """Write into ``folder`` the world's material file and scenario file: ``tables`` (the
    scenario file's tables, this log's shape, seed and name in them) with each key of
    ``edits`` (dotted key -> size: ``aponeurosis.<key>`` of the scenario, ``material.<key>``
    of its material file) edited; returns the scenario file's path.

    Raises:
        LogError: a continuum material, or a key that is not a number, a list of them or a
            table's key of the scenario or its material.
    """
    if not isinstance(base.material, MassSpringMaterial):
        raise LogError(None, "material", "the key edits are written for mass-spring materials")
    material = tomllib.loads(material_to_toml(base.material))
    scenario_tables = {name: dict(table) for name, table in tables.items()}
    for key, size in edits.items():
        table, *path = key.split(".")
        try:
            if table == "material":
                _set(material, path, size, key)
                continue
            section = scenario_tables.setdefault(table, {})
            section.setdefault(path[0], getattr(getattr(base, table), path[0]))
            _set(section, path, size, key)
        except (AttributeError, KeyError, TypeError, ValueError) as error:
            raise LogError(None, key, f"cannot be edited by {size}: {error}") from error
    world_material = material_from_table(material, file=folder / "material.toml")
    write_atomic(folder / "material.toml", material_to_toml(world_material, _HEADER))
    scenario_tables["material"] = {"file": "material.toml"}
    return write_atomic(folder / "scenario.toml", tables_toml(scenario_tables, _HEADER))


def write_key_change_batch(folder: str | Path, seed: int, base: str | Path,
                           causes: Sequence[str] = (), logs: int = LOG_COUNT,
                           end_s: float | None = None,
                           edits: dict[str, float] | None = None) -> LogBatchTruth:
    """Draw a batch from ``seed``: the keys of each of ``causes`` edited by a drawn size
    (:func:`draw_size`) in the world, and the keys of ``edits`` (dotted key -> size, as
    :func:`world_files` takes them) as given, ``logs`` episodes on documented shapes run in it
    and written into ``folder`` as logs of the world the lab believes (``base`` with the log's
    shape); return the truth (the sizes by cause and by edited key: factors, or angles in
    rad). ``end_s`` cuts every episode short (tests).

    Raises:
        LogError: an unknown or repeated cause, a sensor's offset (no key), ``logs`` < 1.
        ScenarioError: the base scenario, or a world it gives, cannot be read.
    """
    folder, base = Path(folder), Path(base)
    unknown = [c for c in causes if c not in CAUSES]
    if unknown or len(set(causes)) != len(causes) or logs < 1:
        raise LogError(None, "causes", f"must be distinct world causes of {list(CAUSES)} and "
                       f"logs >= 1, got {list(causes)} and {logs}")
    scenario = load_scenario(base)
    rng = np.random.default_rng([seed, 72])
    sizes = {cause: draw_size(cause, rng) for cause in causes}
    raw = resolved_tables(read_toml(base), scenario)
    folder.mkdir(parents=True, exist_ok=True)
    write_atomic(folder / "material.toml", material_to_toml(scenario.material, _HEADER))
    shapes, wall_start = [], time.perf_counter()
    for k in range(1, logs + 1):
        shape = documented_shape(int(rng.integers(0, 2**31)), scenario.tissue)
        drawn = {item.name: getattr(shape, item.name) for item in fields(shape)
                 if getattr(shape, item.name) != getattr(scenario.tissue, item.name)}
        belief = replace(scenario, name=f"{scenario.name}-{k}",
                         seed=int(rng.integers(0, 2**31)), end_s=end_s, tissue=shape)
        path = folder / f"log-{k}" / "scenario.toml"
        path.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(path, log_scenario_toml(raw, belief, drawn, _HEADER))
        with tempfile.TemporaryDirectory(prefix="musclecell-world-") as hidden:
            world_tables = tomllib.loads(log_scenario_toml(raw, belief, drawn, _HEADER))
            world = load_scenario(world_files(Path(hidden), scenario, world_tables,
                                              cause_edits(scenario, sizes) | (edits or {})))
            episode = LoggedEpisode(world)
            episode.run()
        write_log(path.parent, episode, path)
        shapes.append(drawn)
    return LogBatchTruth(tuple(causes), seed, sizes | (edits or {}), "", tuple(shapes),
                         time.perf_counter() - wall_start)

