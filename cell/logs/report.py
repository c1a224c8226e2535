"""What the batch diagnosis of separation logs writes (docs/logs.md): ``diagnosis.json``
(the contract), the extended material and scenario a user runs next, and ``report.md`` with
the logged and simulated channels over time, before and after (``channels-<log>.png``, with
the ``report`` extra, matplotlib).
"""

from __future__ import annotations

from dataclasses import fields, is_dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cell.config import read_toml
from cell.diagnosis.engine.determined import NOT_DETERMINED, shown
from cell.extras import require
from cell.logs.causes import SENSOR_OFFSET, changed_world
from cell.logs.fit import FORCE_CHANNELS, logged_vector
from cell.logs.outcome import EVIDENCE_ROWS
from cell.outputs import figure_png, write_atomic, write_json
from cell.sim.scenario import Scenario
from cell.sim.scenariotoml import resolved_tables, tables_toml
from cell.tissue.material import MassSpringMaterial
from cell.tissue.materialfile import material_to_toml

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from cell.logs.batch import LogBatch
    from cell.logs.diagnosis import LogDiagnosis

MATERIAL, SCENARIO = "extended-material.toml", "extended-scenario.toml"
_HEADER = ("The extended world of a batch diagnosis of separation logs (musclecell "
           "diagnose-logs):\nthe first log's scenario with the causes' changes.")


def write_extended(folder: Path, batch: LogBatch, diagnosis: LogDiagnosis) -> list[Path]:
    """The extended material (where it is a mass-spring one) and scenario (the first log's,
    with the causes' changes), into ``folder``."""
    belief = batch.scenarios[0]
    magnitudes = {name: value["magnitude"]
                  for name, value in diagnosis.extended["params"].items()
                  if value.get("magnitude") is not None}
    world = changed_world(belief, magnitudes)
    raw = resolved_tables(read_toml(batch.logs[0].scenario), belief)
    for table, changed in changed_keys(belief, world).items():
        raw[table] = {**raw.get(table, {}), **changed}
    written = []
    if isinstance(world.material, MassSpringMaterial):
        written.append(write_atomic(folder / MATERIAL,
                                    material_to_toml(world.material, _HEADER)))
        raw["material"] = {"file": MATERIAL}
    header = "\n".join([_HEADER, *(f"Not in a scenario's keys: {name} (see diagnosis.json)"
                                   for name in diagnosis.extended["params"]
                                   if name == SENSOR_OFFSET)])
    written.append(write_atomic(folder / SCENARIO, tables_toml(raw, header)))
    return written


def changed_keys(belief: Scenario, world: Scenario) -> dict[str, dict[str, Any]]:
    """The scenario's tables (but the material, written whole) and their keys whose values
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


def write_log_diagnosis(folder: str | Path, batch: LogBatch, diagnosis: LogDiagnosis,
                        plots: bool = True) -> list[Path]:
    """``diagnosis.json``, the extended material and scenario, ``report.md`` and, with
    ``plots``, ``channels-<log>.png`` per log.

    Raises:
        MissingExtraError: ``plots`` without matplotlib (checked before anything is written).
    """
    if plots:
        require("matplotlib", "report", "the log diagnosis's plots")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = [write_json(folder / "diagnosis.json", diagnosis.to_json())]
    written += write_extended(folder, batch, diagnosis)
    figures = _figures(folder, batch, diagnosis) if plots else []
    written += figures
    written.append(write_atomic(folder / "report.md", _markdown(diagnosis, figures)))
    return written


def _figures(folder: Path, batch: LogBatch, diagnosis: LogDiagnosis) -> list[Path]:
    from matplotlib.figure import Figure  # a figure off pyplot: headless, nothing to close

    _, rows = logged_vector(batch.logs, EVIDENCE_ROWS)
    out = []
    for i, log in enumerate(batch.logs):
        figure = _draw_log(Figure(figsize=(9, 7), layout="constrained"), log, i, rows,
                           diagnosis.simulated)
        out.append(write_atomic(folder / f"channels-{i + 1}.png", figure_png(figure, 100)))
    return out


def _draw_log(figure: Figure, log: Any, index: int, rows: Any,
              vectors: dict[str, np.ndarray]) -> Figure:
    """Each force channel's components over time: logged, baseline, extended."""
    axes = figure.subplots(len(FORCE_CHANNELS), 1, sharex=True)
    styles = {"measured": ("k", "-", "logged"), "baseline": ("tab:blue", "--", "baseline"),
              "extended": ("tab:red", "-", "extended")}
    for c, (ax, name) in enumerate(zip(axes, FORCE_CHANNELS, strict=True)):
        t = log.channels[name].time_s
        mine = (rows.log == index) & (rows.channel == c)
        for key, (color, dash, label) in styles.items():
            values = vectors[key][mine].reshape(-1, 3)
            for k in range(3):
                ax.plot(t, values[:, k], color=color, linestyle=dash, linewidth=0.8,
                        alpha=(1.0, 0.6, 0.35)[k], label=label if k == 0 else None)
        ax.set_ylabel(f"{name} force, N")
    axes[0].set_title(f"{log.name}: x, y, z components (darker to lighter)")
    axes[0].legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("time, s")
    return figure


def _markdown(diagnosis: LogDiagnosis, figures: list[Path]) -> str:
    data = diagnosis.to_json()
    causes = ", ".join(data["causes"]) or "none: the lab's world explains the logs"
    lines = ["# Diagnosis of a batch of separation logs", "",
             f"Logs: {', '.join(data['logs'])}.", "", f"Causes, most important first: {causes}.",
             "", f"Held-out force RMSE (leave one log out): baseline "
             f"{shown(data['baseline']['heldout_rmse_N'], '.3f')} N, extended "
             f"{shown(data['extended']['heldout_rmse_N'], '.3f')} N, gain "
             f"{shown(data['gain'], '.2f')}.", "",
             "| cause | magnitude | held-out RMSE alone (linearised), N | selected |",
             "| --- | --- | --- | --- |"]
    for c in data["candidates"]:
        lines.append(f"| {c['cause']} | {_short(c['params'])} | "
                     f"{shown(c['heldout_rmse_N'], '.3f')} | "
                     f"{'yes' if c['selected'] else ''} |")
    lines += ["", "Extended world: " + ", ".join(
        f"{k} ({_short(v)})" for k, v in data["extended"]["params"].items()) + "." if
        data["extended"]["params"] else "Extended world: the lab's.", ""]
    for e in data["evidence"]:
        name = f"{e['cause']} ({e['channel']})" if "channel" in e else e["cause"]
        lines.append(f"- {name}: held-out {shown(e['heldout_rmse_with_N'], '.3f')} N with it, "
                     f"{shown(e['heldout_rmse_without_N'], '.3f')} N without (linearised); "
                     f"improves {e['improved_fraction']:.0%} of the logs")
    t = data["timing"]
    lines += ["", f"{t['replays']} replays, {t['replay_wall_s']:.0f} s; the fits "
              f"{t['fit_s']:.1f} s.", ""]
    lines += [f"![Logged, baseline and extended channels]({p.name})" for p in figures]
    return "\n".join(lines) + "\n"


def _short(value: Any) -> str:
    """A value of the JSON in a line: dicts and lists spelt out, a ``null`` number as not
    determined (its ``_reason`` left to the JSON)."""
    if value is None:
        return NOT_DETERMINED
    if isinstance(value, dict):
        return ", ".join(f"{k} {_short(v)}" for k, v in value.items()
                         if not k.endswith("_reason"))
    if isinstance(value, list):
        return "[" + ", ".join(_short(v) for v in value) + "]"
    return f"{value:.3g}" if isinstance(value, float) else str(value)
