"""A report of a diagnosis for a person to read first: where the baseline is wrong, and what
the extended model changes.

:func:`write_report` writes three files into a folder:

- ``forces.png``: per test, the measured force and the baseline's and the extended model's
  held-out predictions (each from a fit without that test, the extended one with its 90 %
  interval) against time;
- ``residuals.png``: the held-out residuals (measured minus predicted) against nominal strain,
  strain rate, time in hold, fibre angle, tension or compression and loading or unloading;
- ``cause-<name>.png``: per named cause, the tests where it shows, predicted held out with it
  and without it (:mod:`cell.diagnosis.specimen.plots`);
- ``report.md``: the causes, the gain, the evidence of each cause, the specimens' spread and
  the coverage of the held-out predictions' 90 % intervals, the candidates, the selection
  steps and the extended model's parameters, with links to the figures.

Plots need matplotlib (the ``report`` extra); it is imported only when a report is written.
Usage (a diagnosis takes minutes, so this is not run as an example)::

    write_report(diagnose(load_measurement_set("assets/measured/beef_round_example")),
                 Path("out/diagnosis"))
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from cell.diagnosis.engine.determined import NOT_DETERMINED, NOT_IDENTIFIABLE, is_determined, shown
from cell.extras import require
from cell.outputs import figure_png, write_together

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from cell.diagnosis.cut.search import CutDiagnosis
    from cell.diagnosis.engine.outcome import Evidence
    from cell.diagnosis.specimen.diagnosis import Diagnosis, ModelFit
    from cell.measure.specimens import MechanicalTest, Specimen

_DPI = 110
_COLUMNS = 4
# Displacement change, as a fraction of the test's range, that ends a hold.
_HOLD_TOLERANCE = 1e-3
_BASELINE, _EXTENDED = "tab:red", "tab:blue"


def write_report(diagnosis: Diagnosis, folder: Path,
                 material_path: Path | None = None) -> list[Path]:
    """Write ``forces.png``, ``residuals.png``, a ``cause-CAUSE.png`` per cause named and
    ``report.md`` into ``folder`` (created if missing), as one change
    (:func:`cell.outputs.write_together`); ``material_path`` is where the extended material's
    TOML is.

    Raises:
        MissingExtraError: matplotlib is not installed.
    """
    require("matplotlib", "report", "the diagnosis report")
    from matplotlib.figure import Figure  # a figure off pyplot: headless, nothing to close

    from cell.diagnosis.specimen.plots import draw_cause

    folder = Path(folder)
    contents: dict[Path, str | bytes] = {
        folder / "forces.png": figure_png(_draw_forces(Figure(layout="constrained"), diagnosis),
                                          _DPI),
        folder / "residuals.png": figure_png(
            _draw_residuals(Figure(layout="constrained"), diagnosis), _DPI),
        **{folder / f"cause-{e.cause}.png": figure_png(
            draw_cause(Figure(layout="constrained"), diagnosis, e), _DPI)
           for e in diagnosis.evidence}}
    contents[folder / "report.md"] = _markdown(diagnosis, folder, material_path, "forces.png",
                                               "residuals.png")
    return write_together(contents)


def _draw_forces(figure: Figure, diagnosis: Diagnosis) -> Figure:
    """One panel per test: measured force, baseline and extended held-out predictions."""
    tests = diagnosis.series
    rows = math.ceil(len(tests) / _COLUMNS)
    columns = min(len(tests), _COLUMNS)
    figure.set_size_inches(4.0 * columns, 2.9 * rows + 0.6)
    axes = figure.subplots(rows, columns, squeeze=False).ravel()
    for k, (ax, test) in enumerate(zip(axes, tests, strict=False)):
        ax.plot(test.time_s, test.force_n, ".", color="0.45", markersize=2.5, label="measured")
        ax.plot(test.time_s, diagnosis.extended.heldout_force_n[k], color=_EXTENDED,
                label=f"extended held-out ({diagnosis.extended.heldout_rmse_n:.3g} N RMSE)")
        if diagnosis.intervals is not None:
            ax.fill_between(test.time_s, diagnosis.intervals.lower_n[k],
                            diagnosis.intervals.upper_n[k], color=_EXTENDED, alpha=0.15,
                            linewidth=0, label="its 90 % interval")
        # Dashed, so that it shows on the extended when no cause was accepted.
        ax.plot(test.time_s, diagnosis.baseline.heldout_force_n[k], "--", color=_BASELINE,
                label=f"baseline held-out ({diagnosis.baseline.heldout_rmse_n:.3g} N RMSE)")
        ax.set_title(f"{test.test_id}: {test.mode}, {test.angle_deg:g}°", fontsize=10)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("force (N)")
    for ax in axes[len(tests):]:
        ax.set_visible(False)
    figure.legend(*axes[0].get_legend_handles_labels(), loc="outside upper center", ncols=3)
    return figure


def _hold_time_s(test: MechanicalTest) -> np.ndarray:
    """Time since the displacement last moved by more than the tolerance, s (0 while moving)."""
    tolerance = _HOLD_TOLERANCE * max(float(np.ptp(test.displacement_m)), 1e-12)
    hold = np.zeros(len(test.time_s))
    anchor = 0
    for i in range(1, len(hold)):
        if abs(test.displacement_m[i] - test.displacement_m[anchor]) > tolerance:
            anchor = i
        hold[i] = test.time_s[i] - test.time_s[anchor]
    return hold


def _features(test: MechanicalTest, specimen: Specimen) -> dict[str, np.ndarray]:
    """Per sample: strain, strain rate (1/s), time in hold (s), and the categories' codes."""
    strain = test.strain(specimen)
    with np.errstate(divide="ignore", invalid="ignore"):
        rate = np.gradient(strain, test.time_s)
        loading = np.sign(np.gradient(np.abs(strain), test.time_s))
    hold = _hold_time_s(test)
    return {
        "strain": strain,
        "rate": np.where(np.isfinite(rate), rate, 0.0),
        "hold": hold,
        "angle": np.full(len(strain), test.angle_deg),
        "tension": (strain > 0).astype(float),
        "loading": np.where(hold > 0, 1.0, np.where(loading > 0, 2.0, 0.0)),
    }


# Panel key, x label, tick labels of a categorical panel (None for a continuous one).
_PANELS = (
    ("strain", "nominal strain", None),
    ("rate", "strain rate (1/s)", None),
    ("hold", "time in hold (s)", None),
    ("angle", "fibre angle (deg)", None),
    ("tension", "sign of strain", ("compression", "tension")),
    ("loading", "sign of d|strain|/dt", ("unloading", "hold", "loading")),
)


def _draw_residuals(figure: Figure, diagnosis: Diagnosis) -> Figure:
    """Six panels of held-out residuals, baseline dark, extended light beside it."""
    data = diagnosis.measurements
    features = [_features(t, data.specimen) for t in diagnosis.series]
    figure.set_size_inches(13.0, 7.6)
    axes = figure.subplots(2, 3).ravel()
    # Fit, label, colour, opacity, side of its strip on categorical panels.
    fits = ((diagnosis.baseline, "baseline", _BASELINE, 0.55, -1.0),
            (diagnosis.extended, "extended", _EXTENDED, 0.2, 1.0))
    jitter = np.random.default_rng(0).uniform(-0.6, 0.6, sum(len(f["strain"]) for f in features))
    for ax, (key, label, ticks) in zip(axes, _PANELS, strict=True):
        x = np.concatenate([f[key] for f in features])
        spread = 0.12 if ticks else 0.0
        if key == "angle":
            spread = 0.03 * max(float(np.ptp(x)), 30.0)
        for fit, name, color, alpha, side in fits:
            ax.scatter(x + (side + jitter) * spread, _residual(fit, diagnosis.series), s=4,
                       color=color, alpha=alpha, linewidths=0, label=f"{name}: {fit.model.name}")
        ax.axhline(0.0, color="0.3", linewidth=0.8)
        ax.set_xlabel(label)
        ax.set_ylabel("measured - held-out (N)")
        if key == "rate":
            ax.set_xscale("symlog", linthresh=max(1e-2 * float(np.abs(x).max()), 1e-9))
        if ticks:
            ax.set_xticks(range(len(ticks)), ticks)
    figure.legend(*axes[0].get_legend_handles_labels(), loc="outside upper center", ncols=2,
                  markerscale=4)
    return figure


def _residual(fit: ModelFit, tests: tuple[MechanicalTest, ...]) -> np.ndarray:
    return np.concatenate([t.force_n - f for t, f in zip(tests, fit.heldout_force_n,
                                                          strict=True)])


def evidence_table(evidence: tuple[Evidence, ...]) -> list[str]:
    """The evidence section's table: per cause, held-out RMSE with and without it, the share
    of tests it improves, its parameters with 95 % intervals (the cut report's too)."""
    lines = ["## Evidence", "", "| cause | held-out RMSE with (N) | without (N) | tests improved "
             "| parameters (95 % interval) |", "|---|---|---|---|---|"]
    for e in evidence:
        values = "; ".join(f"{n} {shown(v, '.3g')} {_interval_text(lo, hi)}"
                           for n, (v, lo, hi) in e.params.items()) or "-"
        lines.append(f"| {e.cause} | {shown(e.heldout_rmse_with_n, '.4g')} | "
                     f"{shown(e.heldout_rmse_without_n, '.4g')} | {e.improved_fraction:.0%} | "
                     f"{values} |")
    return [*lines, ""]


def per_mode_table(evidence: tuple[Evidence, ...]) -> list[str]:
    """In a set of several kinds of test: per cause and mode, the held-out RMSE with and
    without the cause, and the mode that revealed it (the largest ratio); none otherwise."""
    shown_modes = [e for e in evidence if e.per_mode]
    if not shown_modes:
        return []
    lines = ["Each cause per mode (held-out RMSE over that mode's tests):", "",
             "| cause | mode | with (N) | without (N) | revealed by |", "|---|---|---|---|---|"]
    for e in shown_modes:
        lines += [f"| {e.cause} | {mode} | {with_:.4g} | {without:.4g} | "
                  f"{'yes' if mode == e.revealed_by else ''} |"
                  for mode, (with_, without) in e.per_mode.items()]
    return [*lines, ""]


def _interval_text(low: float, high: float) -> str:
    """An interval as ``[low, high]``, or said to be not determined
    (:mod:`cell.diagnosis.engine.determined`)."""
    if is_determined([low, high]):
        return f"[{low:.3g}, {high:.3g}]"
    return f"[interval {NOT_DETERMINED}: {NOT_IDENTIFIABLE}]"


def _evidence_lines(diagnosis: Diagnosis) -> list[str]:
    """The evidence section: :func:`evidence_table` and each cause's figure."""
    if not diagnosis.evidence:
        return []
    lines = evidence_table(diagnosis.evidence) + per_mode_table(diagnosis.evidence)
    lines += [f"![{e.cause}: with and without it](cause-{e.cause}.png)" for e in diagnosis.evidence]
    return [*lines, ""]


def _interval_lines(diagnosis: Diagnosis) -> list[str]:
    """The specimens and the held-out predictions' 90 % intervals: the spread between repeats,
    the coverage of each test's samples by its interval, the parts of the intervals."""
    spread, intervals = diagnosis.specimen, diagnosis.intervals
    lines = ["## Specimens and predictions with intervals", ""]
    if spread.specimens:
        lines += [f"{len(spread.specimens)} named specimens, each held out whole; the spread "
                  f"of their modulus factor: coefficient of variation {shown(spread.cv, '.3g')} "
                  f"(sd of the log factor {shown(spread.sd, '.3g')} "
                  f"{_interval_text(*spread.ci95)}), likelihood ratio "
                  f"{shown(spread.likelihood_ratio, '.3g')} against none (named above "
                  f"{spread.critical:.3g}).", "",
                  "| specimen | modulus factor | 95 % interval | tests |", "|---|---|---|---|"]
        lines += [f"| {name} | {f.factor:.3g} | {f.low:.3g} to {f.high:.3g} | "
                  f"{', '.join(f.tests)} |" for name, f in spread.specimens.items()]
        lines.append("")
    elif spread.groups:
        lines += [f"{len(spread.groups)} groups of tests under equal conditions; the spread "
                  f"between their specimens (sd of the log modulus factor) "
                  f"{shown(spread.sd, '.3g')} {_interval_text(*spread.ci95)}, likelihood ratio "
                  f"{shown(spread.likelihood_ratio, '.3g')} "
                  f"against none (named above {spread.critical:.3g}).", ""]
    else:
        lines += ["No tests under equal conditions: the spread between specimens is not "
                  "measured, and the intervals hold it in the model's discrepancy.", ""]
    if intervals is None:
        return lines
    parts = ", ".join(f"{name} {shown(value, '.3g')} N"
                      for name, value in intervals.parts_n.items())
    lines += [f"The 90 % intervals of the held-out predictions cover "
              f"{intervals.overall_coverage:.1%} of the held-out samples (RMS parts: {parts}).",
              "", "| test | coverage | discrepancy (relative) |", "|---|---|---|"]
    lines += [f"| {t} | {c:.0%} | {shown(d, '.3g')} |" for t, c, d in
              zip(intervals.test_ids, intervals.coverage, intervals.discrepancy, strict=True)]
    return [*lines, ""]


def _markdown(diagnosis: Diagnosis, folder: Path, material_path: Path | None, forces: str,
              residuals: str) -> str:
    """``report.md``: causes, gain, errors, candidates, steps, parameters, links."""
    causes = (f"Causes, most important first: {', '.join(diagnosis.causes)}."
              if diagnosis.causes else "No cause found: the baseline explains the data.")
    lines = [
        f"# Diagnosis of {diagnosis.measurements.specimen.name}", "", causes, "",
        gain_line(diagnosis), "",
        *_evidence_lines(diagnosis), *_interval_lines(diagnosis),
        *search_lines(diagnosis, folder, material_path),
        f"![Measured and held-out forces]({forces})", "",
        f"![Held-out residuals]({residuals})", "",
    ]
    return "\n".join(lines)


def gain_line(diagnosis: Diagnosis | CutDiagnosis) -> str:
    """The gain and the held-out errors it comes from (the cut report's too)."""
    return (f"Gain {shown(diagnosis.gain, '.3f')}: held-out RMSE "
            f"{shown(diagnosis.baseline.heldout_rmse_n, '.4g')} N (baseline) → "
            f"{shown(diagnosis.extended.heldout_rmse_n, '.4g')} N (extended); noise "
            f"{diagnosis.noise_n:.3g} N.")


def search_lines(diagnosis: Diagnosis | CutDiagnosis, folder: Path,
                 material_path: Path | None) -> list[str]:
    """The search's sections of a report: the candidates, the steps and the extended model's
    parameters, then the link to the material's file (relative to ``folder``) when there is
    one; the uniaxial and the cut report share them."""
    lines = ["## Candidates", "", "| cause | held-out RMSE (N) | BIC | selected |",
             "|---|---|---|---|"]
    for fit in (diagnosis.baseline, *diagnosis.candidates):
        cause = ", ".join(fit.model.causes) or "none (baseline)"
        selected = "yes" if set(fit.model.causes) & set(diagnosis.causes) else ""
        lines.append(f"| {cause} | {shown(fit.heldout_rmse_n, '.4g')} | {shown(fit.bic, '.1f')} "
                     f"| {selected} |")
    lines += ["", "## Steps", ""]
    lines += [f"{k}. {' + '.join(fit.model.causes)}: held-out RMSE "
              f"{shown(fit.heldout_rmse_n, '.4g')} N, BIC {shown(fit.bic, '.1f')}"
              for k, fit in enumerate(diagnosis.steps, start=1)]
    if not diagnosis.steps:
        lines.append("No cause was accepted.")
    lines += _second_look_lines(diagnosis)
    extended = diagnosis.extended
    lines += ["", f"## Extended model: {extended.model.name}", "", "| parameter | value |",
              "|---|---|"]
    lines += [f"| {name} | {shown(value, '.4g')} |" for name, value in extended.params.items()]
    lines.append("")
    if material_path is not None:
        link = Path(os.path.relpath(Path(material_path).absolute(), folder.absolute()))
        lines += [f"Material TOML: [{material_path}]({link.as_posix()})", ""]
    return lines


def _second_look_lines(diagnosis: Diagnosis | CutDiagnosis) -> list[str]:
    """What the second look tried where the search stopped with more than noise left: each
    selected cause swapped for each other cause, and which swap was kept."""
    if not diagnosis.swaps:
        return []
    lines = ["", "### Second look", "",
             "The search stopped with more than noise left, so each selected cause was "
             "swapped for each other cause of the catalogue:", "",
             "| removed | added | held-out RMSE (N) | kept |", "|---|---|---|---|"]
    lines += [f"| {swap.removed} | {swap.added} | {shown(swap.fit.heldout_rmse_n, '.4g')} | "
              f"{'yes' if swap.kept else ''} |" for swap in diagnosis.swaps]
    return lines
