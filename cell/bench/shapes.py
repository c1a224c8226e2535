"""Muscle shapes drawn from the documented ranges: the default randomisation's ``[tissue.*]``
tables (``assets/randomization/default.toml``), one shape per seed; and the scenario's episode
on each (``musclecell bench perception --shapes N``): how well the cut follows the interface
on meat the generic model does not know.

The valley's width is left to the shape to derive (:attr:`MuscleShape.valley_decay_m`), as a
user who gives the other dimensions leaves it.

Example:
    >>> shape = documented_shape(1)
    >>> 0.40 <= shape.length_m <= 0.50, shape.valley_width_m is None
    (True, True)
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from cell.bench.parts import Progress, measured
from cell.errors import MusclecellError
from cell.sim.episode import Episode
from cell.sim.scenario import Scenario
from cell.tissue.geometry import MuscleShape
from envs.randomization import Randomization, load_randomization

#: Shape fields the draw leaves to the shape's own derivation.
DERIVED_FIELDS = ("valley_width_m",)
#: The shape's parameters in the table (with the valley width in use).
SHAPE_COLUMNS = ("length_m", "round_width_m", "shank_width_m", "round_height_m",
                 "shank_height_m", "interface_bow_m", "interface_lean", "valley_depth_m",
                 "edge_radius_m", "end_taper")
#: Issue 13's targets per episode: the tip's distance to the true interface, m, and the
#: released and torn fractions of the bindings.
TARGETS = {"tip_mean_m": 0.003, "tip_max_m": 0.008, "released_fraction": 0.95,
           "torn_fraction": 0.20}


def documented_shape(seed: int, base: MuscleShape | None = None,
                     randomization: Randomization | None = None) -> MuscleShape:
    """``base`` (the default shape) with every documented shape range drawn once from
    ``seed`` but :data:`DERIVED_FIELDS`.

    Raises:
        InputError: a drawn shape the checks refuse (the ranges are checked where they are
            loaded, so only a ``base`` outside them can).
    """
    randomization = load_randomization() if randomization is None else randomization
    rng = np.random.default_rng(seed)
    drawn = {}
    for key, distribution in randomization.entries:
        if key.startswith("tissue."):
            drawn[key.removeprefix("tissue.")] = float(distribution.sample(rng))
    kept = {name: value for name, value in drawn.items() if name not in DERIVED_FIELDS}
    return replace(MuscleShape() if base is None else base, **kept)


def _shape_row(seed: int, shape: MuscleShape, scenario: Scenario) -> dict[str, Any]:
    """One episode of the scenario on ``shape``: the table's row (SI units)."""
    row: dict[str, Any] = {"seed": seed, "shape": {name: getattr(shape, name)
                                                   for name in SHAPE_COLUMNS}}
    row["shape"]["valley_width_m"] = shape.valley_decay_m
    try:
        summary = Episode(replace(scenario, tissue=shape)).run()
    except MusclecellError as error:
        return row | {"status": type(error).__name__, "error": str(error)}
    result, timing = summary["result"], summary["timing"]
    tip, damage = result["knife_tip_to_true_interface_m"], result["flesh_damage"]
    return row | {
        "status": "ok",
        "tip_to_interface_m": {"mean": tip["mean"], "p95": tip["p95"], "max": tip["max"],
                               "max_at": tip["max_at"],
                               "passes": [{"mean": p["mean"], "max": p["max"]}
                                          for p in tip["passes"]]},
        "released_fraction": result["released_fraction"],
        "torn_fraction": damage["torn_fraction"],
        "flesh_damage": {"blade_area_in_flesh_m2": damage["blade_area_in_flesh_m2"],
                         "blade_volume_in_flesh_m3": damage["blade_volume_in_flesh_m3"],
                         "bindings_missed": damage["bindings_missed"]},
        "perception_updates": len(result.get("perception", {}).get("updates", [])),
        "perception_s": timing["perception_s"],
        "real_time_factor": timing["real_time_factor"],
    }


def bench_shapes(scenario: Scenario, seeds: range, progress: Progress = None
                 ) -> dict[str, Any]:
    """The scenario's episode on one documented shape per seed: per shape its parameters,
    the tip's distance to the true interface (mean and max, per pass), released and torn
    fractions and flesh damage, and how many met the targets (:data:`TARGETS`);
    ``progress`` hears of each shape as it finishes."""
    rows = list(measured({f"shape {seed}": lambda seed=seed: _shape_row(
        seed, documented_shape(seed, scenario.tissue), scenario) for seed in seeds},
        progress).values())
    met = [row for row in rows if row["status"] == "ok"
           and row["tip_to_interface_m"]["mean"] <= TARGETS["tip_mean_m"]
           and row["tip_to_interface_m"]["max"] <= TARGETS["tip_max_m"]
           and row["released_fraction"] >= TARGETS["released_fraction"]
           and row["torn_fraction"] <= TARGETS["torn_fraction"]]
    return {"targets": TARGETS, "shapes": rows, "met": len(met), "of": len(rows),
            "seeds": [seeds.start, seeds.stop]}


def shape_lines(table: dict[str, Any]) -> list[str]:
    """One line per shape of :func:`bench_shapes`'s table (tip error in mm, released and
    torn), and how many met every target."""
    lines = []
    for row in table["shapes"]:
        if row["status"] != "ok":
            lines.append(f"shape {row['seed']}: {row['status']}: {row['error']}")
            continue
        tip = row["tip_to_interface_m"]
        passes = ", ".join(f"{p['mean'] * 1e3:.1f}/{p['max'] * 1e3:.1f}" for p in tip["passes"])
        lines.append(f"shape {row['seed']}: tip {tip['mean'] * 1e3:.1f} mm mean, "
                     f"{tip['max'] * 1e3:.1f} max (per pass {passes}); released "
                     f"{row['released_fraction']:.0%}, torn {row['torn_fraction']:.0%}")
    return [*lines, f"shapes meeting every target: {table['met']} of {table['of']}"]
