"""What the batch diagnosis of separation logs writes (docs/logs.md): ``diagnosis.json``
(the contract), the extended material and scenario a user runs next, and ``report.md`` with
the logged and simulated channels over time, before and after (``channels-<log>.png``, with
the ``report`` extra, matplotlib).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cell.config import read_toml
from cell.diagnosis.engine.determined import NOT_DETERMINED, shown
from cell.extras import require
from cell.logs.causes import CAUSES, SENSOR_OFFSET, changed_keys, changed_world, scenario_keys
from cell.logs.fit import COMPARED_WINDOW_S, FORCE_CHANNELS, logged_vector
from cell.logs.outcome import EVIDENCE_ROWS
from cell.outputs import figure_png, write_atomic, write_json
from cell.sim.scenario import Scenario
from cell.sim.scenariotoml import resolved_tables, tables_toml
from cell.tissue.materialfile import material_to_toml

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from cell.logs.batch import LogBatch
    from cell.logs.diagnosis import LogDiagnosis

MATERIAL, SCENARIO = "extended-material.toml", "extended-scenario.toml"
_HEADER = ("The extended world of a batch diagnosis of separation logs (musclecell "
           "diagnose-logs):\nthe first log's scenario with the causes' changes.")


def write_extended(folder: Path, batch: LogBatch, diagnosis: LogDiagnosis) -> list[Path]:
    """The extended material and scenario (the first log's, with the causes' changes), into
    ``folder``."""
    magnitudes = {name: value["magnitude"]
                  for name, value in diagnosis.extended["params"].items()
                  if value.get("magnitude") is not None}
    not_keys = [name for name in diagnosis.extended["params"] if name == SENSOR_OFFSET]
    return write_extended_world(folder, batch.logs[0].scenario, batch.scenarios[0], magnitudes,
                                not_keys)


def write_extended_world(folder: Path, scenario_file: Path, belief: Scenario,
                         magnitudes: dict[str, float], not_keys: list[str]) -> list[Path]:
    """``scenario_file`` (loaded as ``belief``) with the world causes of ``magnitudes``
    applied, as ``extended-scenario.toml`` and its material (either kind) as
    ``extended-material.toml``: loaded, the scenario is the world the causes made. The causes
    of ``not_keys`` have no scenario key and are named in the scenario's header."""
    world = changed_world(belief, magnitudes)
    raw = resolved_tables(read_toml(scenario_file), belief)
    for table, changed in changed_keys(belief, world).items():
        raw[table] = {**raw.get(table, {}), **changed}
    written = [write_atomic(folder / MATERIAL, material_to_toml(world.material, _HEADER))]
    raw["material"] = {"file": MATERIAL}
    header = "\n".join([_HEADER, *(f"Not in a scenario's keys: {name} (see diagnosis.json)"
                                   for name in not_keys)])
    written.append(write_atomic(folder / SCENARIO, tables_toml(raw, header)))
    return written


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
    written.append(write_atomic(folder / "report.md",
                                _markdown(diagnosis, figures, batch.scenarios[0])))
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


def _markdown(diagnosis: LogDiagnosis, figures: list[Path], belief: Scenario) -> str:
    data = diagnosis.to_json()
    causes = ", ".join(data["causes"]) or "none: the lab's world explains the logs"
    lines = ["# Diagnosis of a batch of separation logs", "",
             f"Logs: {', '.join(data['logs'])}.", "", f"Causes, most important first: {causes}.",
             "", f"Held-out force RMSE (leave one log out; the forces averaged over "
             f"{COMPARED_WINDOW_S:g} s): baseline "
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
    keys = [f"- {name} changes {', '.join(f'`{key}`' for key in scenario_keys(name, belief))}"
            f" ({SCENARIO}, {MATERIAL})" for name in data["extended"]["params"] if name in CAUSES]
    lines += [*keys, ""] if keys else []
    for e in data["evidence"]:
        name = f"{e['cause']} ({e['channel']})" if "channel" in e else e["cause"]
        lines.append(f"- {name}: held-out {shown(e['heldout_rmse_with_N'], '.3f')} N with it, "
                     f"{shown(e['heldout_rmse_without_N'], '.3f')} N without (linearised); "
                     f"improves {e['improved_fraction']:.0%} of the logs")
    for pair in data["indistinguishable"]:
        place = _place(pair["differs_most"])
        lines.append(f"- {pair['cause']} cannot be told from {pair['alternative']} on these "
                     f"logs: held-out {shown(pair['heldout_rmse_N'], '.3f')} N against "
                     f"{shown(pair['alternative_heldout_rmse_N'], '.3f')} N (linearised); they "
                     f"differ most in the {place}: a log where that differs tells them apart "
                     "(docs/logs.md, \"Causes told apart\")")
    for open_ in data.get("undetermined_beside", []):
        lines.append(f"- {open_['cause']} may be changed as well: beside "
                     f"{', '.join(open_['beside'])}, refitted, these logs allow it from "
                     f"{_size(open_['low'])} to {_size(open_['high'])} (linearised); its "
                     f"change differs most in the {_place(open_['differs_most'])}: a log "
                     "where that shows tells whether it is there (docs/logs.md, \"Causes "
                     "told apart\")")
    for gone in data["extended"].get("pruned", []):
        read = " (the median of nudged replays)" if gone.get("by") == "spread" else ""
        lines.append(f"- {gone['cause']} left out of the fit: the replays fit "
                     f"{gone['rmse_N']:.3f} N without it, {gone['with_rmse_N']:.3f} N with "
                     f"it{read} (a cause named must lower the replayed error by the gain "
                     "asked)")
    lines += _spread_lines(data["extended"])
    t = data["timing"]
    rounds = ", ".join(f"{count} {name}" for name, count in t["replays_by_round"].items())
    lines += ["", f"{t['replays']} replays ({rounds}), {t['replay_wall_s']:.0f} s; the fits "
              f"{t['fit_s']:.1f} s.", ""]
    lines += [f"![Logged, baseline and extended channels]({p.name})" for p in figures]
    return "\n".join(lines) + "\n"


def _spread_lines(extended: dict[str, Any]) -> list[str]:
    """What the replays' spread said (docs/logs.md): how far the fitted world's replays
    scatter (before the second look), the medians of the nudged replays of the world fitted
    and of the lab's, and the causes it dropped."""
    scatter, lines = extended.get("replay_scatter"), []
    if scatter is not None:
        lines.append(f"- The fitted world's replays: {scatter['median_rmse_N']:.3f} N from the "
                     f"logs (median), {scatter['scatter_N']:.3f} N from each other, the "
                     f"sensors' noise {scatter['noise_N']:.3f} N; "
                     + ("a second look tried" if "second_look" in extended
                        else "a second look found no cause beside the fit"
                        if scatter.get("looked") else "nothing left for a second look"))
    spread = extended.get("spread")
    if spread is None:
        return lines
    dropped = extended.get("dropped", {}).get("causes", []) if not spread["kept"] else []
    verdict = (f"{', '.join(dropped)} not named: no closer than the lab's world" if dropped
               else f"{', '.join(spread['kept'])} hold")
    return [*lines, f"- Replays nudged by {spread['jitter']:.0%} in every cause "
            f"({spread['replays_each']} a world, the median): the world fitted "
            f"{spread['median_rmse_N']:.3f} N, the lab's {spread['lab_median_rmse_N']:.3f} N; "
            f"{verdict}"]


def _place(differs_most: str) -> str:
    """Where two changes differ most (a force channel, or ``outcome``), in words."""
    return ("outcome (the counts and the release times)" if differs_most == "outcome"
            else f"{differs_most} force")


def _size(entry: dict[str, Any]) -> str:
    """A cause's magnitude (:meth:`~cell.logs.causes.cause.LogCause.to_json`) in words: a
    factor, or an angle."""
    if entry.get("angle_deg") is not None:
        return f"{entry['angle_deg']:+.0f} degrees"
    return f"{_short(entry.get('factor'))} times"


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
