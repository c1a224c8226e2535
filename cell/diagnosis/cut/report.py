"""The report of a set's diagnosis for a person to read first, cut tests included.

:func:`write_set_report` writes the uniaxial report
(:func:`cell.diagnosis.specimen.report.write_report`)
when the set has uniaxial tests, and for its cut tests:

- ``cut-forces.png``: per cut test, the force that resists the edge's sinking against the
  depth, measured and held-out predictions of the baseline and the extended cutting model;
  for a sawing cut, a second panel with the force along the edge against the stroke;
- ``cut-residuals.png``, where ``unexplained`` stands: the extended model's held-out residual
  against the depth, the stroke, the stroke's speed and the time, and in ``cut-report.md``
  the quantity it follows most (:mod:`cell.diagnosis.cut.residuals`);
- ``cut-report.md``: the causes, the gain, the evidence of each cause (held-out RMSE with and
  without it, the tests it improves, its parameters with 95 % intervals), the fitted
  parameters against their sources' ranges (those outside flagged), the candidates, the
  steps and the extended cutting model's parameters, with a link to the figure.

Plots need matplotlib (the ``report`` extra), imported only when a report is written.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from cell.diagnosis.cut.causes import source_checks
from cell.diagnosis.cut.reduced import cutting_direction
from cell.diagnosis.cut.residuals import (
    ResidualTrend,
    ScalesBetweenTests,
    cut_quantities,
    strongest,
)
from cell.diagnosis.specimen.report import evidence_table, gain_line, search_lines
from cell.extras import require
from cell.outputs import figure_png, write_atomic

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from cell.diagnosis.sets import SetDiagnosis

_DPI = 110
_BASELINE, _EXTENDED = "tab:red", "tab:blue"
#: A cut whose edge travels more than this along itself is drawn as a sawing cut too, m.
_SAWING_STROKE_M = 1e-3


def write_set_report(diagnosis: SetDiagnosis, folder: Path,
                     material_path: Path | None = None) -> list[Path]:
    """Write the reports of ``diagnosis``'s parts into ``folder`` (module docstring).

    Raises:
        MissingExtraError: matplotlib is not installed.
    """
    require("matplotlib", "report", "the diagnosis report")
    from matplotlib.figure import Figure

    written = []
    if diagnosis.uniaxial is not None:
        from cell.diagnosis.specimen.report import write_report

        written += write_report(diagnosis.uniaxial, folder, material_path)
    if diagnosis.cut is not None:
        folder = Path(folder)
        forces = write_atomic(folder / "cut-forces.png",
                              figure_png(_draw_cuts(Figure(layout="constrained"), diagnosis),
                                         _DPI))
        written.append(forces)
        if diagnosis.cut.residual_trends:
            written.append(write_atomic(folder / "cut-residuals.png", figure_png(
                _draw_residuals(Figure(layout="constrained"), diagnosis), _DPI)))
        written.append(write_atomic(folder / "cut-report.md",
                                    _markdown(diagnosis, folder, material_path, forces.name)))
    return written


def _series(flat_force: np.ndarray) -> np.ndarray:
    """A force series channel after channel back as (n, 3)."""
    return np.asarray(flat_force).reshape(3, -1).T


def _draw_cuts(figure: Figure, diagnosis: SetDiagnosis) -> Figure:
    """One row per cut test: force against depth, and against the stroke for a sawing cut."""
    data, cut = diagnosis.measurements, diagnosis.cut
    down = cutting_direction(data.blade)
    along = np.asarray(data.blade.edge_direction)
    tests = data.cut_tests
    figure.set_size_inches(9.0, 2.8 * len(tests) + 0.6)
    axes = figure.subplots(len(tests), 2, squeeze=False)
    fits = (("measured", None), ("baseline held-out", cut.baseline),
            ("extended held-out", cut.extended))
    for k, test in enumerate(tests):
        depth, stroke = test.depth_m(data.block), test.stroke_m(data.blade)
        for label, fit in fits:
            force = test.force_n if fit is None else _series(fit.heldout_force_n[k])
            style = dict(marker=".", linestyle="none", color="0.45", markersize=2.5) \
                if fit is None else dict(color=_BASELINE if fit is cut.baseline else _EXTENDED,
                                         linestyle="--" if fit is cut.baseline else "-")
            axes[k, 0].plot(1e3 * depth, -force @ down, label=label, **style)
            axes[k, 1].plot(1e3 * stroke, force @ along, label=label, **style)
        axes[k, 0].set_title(f"{test.test_id}: force against depth", fontsize=10)
        axes[k, 0].set_xlabel("depth below the top face (mm)")
        axes[k, 0].set_ylabel("force against the cut (N)")
        sawing = float(np.ptp(stroke)) > _SAWING_STROKE_M
        axes[k, 1].set_visible(sawing)
        axes[k, 1].set_title(f"{test.test_id}: force along the edge", fontsize=10)
        axes[k, 1].set_xlabel("stroke (mm)")
        axes[k, 1].set_ylabel("force along the edge (N)")
    figure.legend(*axes[0, 0].get_legend_handles_labels(), loc="outside upper center", ncols=3)
    return figure


def _draw_residuals(figure: Figure, diagnosis: SetDiagnosis) -> Figure:
    """The extended model's held-out residual of the force against the cut and along the
    edge, against each quantity the tests vary
    (:func:`cell.diagnosis.cut.residuals.cut_quantities`),
    every test's samples together."""
    data, fit = diagnosis.measurements, diagnosis.cut.extended
    directions = (("against the cut", -cutting_direction(data.blade)),
                  ("along the edge", np.asarray(data.blade.edge_direction)))
    quantities = [cut_quantities(test, data.block, data.blade) for test in data.cut_tests]
    residuals = [test.force_n - _series(pred)
                 for test, pred in zip(data.cut_tests, fit.heldout_force_n, strict=True)]
    names = list(quantities[0])
    figure.set_size_inches(3.0 * len(names), 5.6)
    axes = figure.subplots(len(directions), len(names), squeeze=False)
    for row, (component, direction) in enumerate(directions):
        for column, name in enumerate(names):
            for quantity, residual in zip(quantities, residuals, strict=True):
                axes[row, column].plot(quantity[name], residual @ direction, ".",
                                       markersize=1.5, alpha=0.5)
            axes[row, column].set_xlabel(name)
            axes[row, column].set_ylabel(f"residual {component} (N)")
    figure.suptitle("Held-out residual of the extended model (measured less predicted), "
                    "one colour a test")
    return figure


def _markdown(diagnosis: SetDiagnosis, folder: Path, material_path: Path | None,
              forces: str) -> str:
    """``cut-report.md``: causes, gain, candidates, steps, parameters, links."""
    cut = diagnosis.cut
    causes = (f"Causes, most important first: {', '.join(cut.causes)}." if cut.causes
              else "No cause found: the constant toughness explains the cuts.")
    lines = [f"# Diagnosis of the cut tests of {diagnosis.measurements.folder.name}", "",
             causes, "",
             gain_line(cut), "",
             *(evidence_table(cut.evidence) if cut.evidence else []),
             *_source_lines(cut.extended.params),
             *_trend_lines(cut.residual_trends),
             *_scale_lines(cut.between_tests),
             *(["![The residual against what the tests vary](cut-residuals.png)", ""]
               if cut.residual_trends else []),
             *search_lines(cut, folder, material_path),
             f"![Measured and held-out cut forces]({forces})", ""]
    return "\n".join(lines)


def _trend_lines(trends: tuple[ResidualTrend, ...]) -> list[str]:
    """Where ``unexplained`` stands: what the held-out residual follows, the strongest first
    (:mod:`cell.diagnosis.cut.residuals`)."""
    if not trends:
        return []
    top = strongest(trends)
    lead = (f"The residual follows **{top.quantity}** most (the force {top.component}: rank "
            f"correlation {top.rank_correlation:+.2f} [{top.ci95[0]:+.2f}, "
            f"{top.ci95[1]:+.2f}])." if top is not None else
            "No quantity of the tests clearly orders the residual.")
    lines = ["## Where the model is still wrong", "", lead, "",
             "| quantity | force | rank correlation | 95 % interval (resampled tests) |",
             "|---|---|---|---|"]
    lines += [f"| {t.quantity} | {t.component} | {t.rank_correlation:+.2f} | "
              + (f"[{t.ci95[0]:+.2f}, {t.ci95[1]:+.2f}]" if t.ci95 else "not determined")
              + " |" for t in trends]
    return [*lines, ""]


def _scale_lines(scales: ScalesBetweenTests | None) -> list[str]:
    """Where ``unexplained`` stands: how much of the residual one factor per test on the
    prediction removes, and what the factors follow most."""
    if scales is None:
        return []
    top = strongest(scales.trends)
    follows = (f"; they follow the tests' **{top.quantity}** most (rank correlation "
               f"{top.rank_correlation:+.2f} [{top.ci95[0]:+.2f}, {top.ci95[1]:+.2f}])"
               if top is not None else "; no quantity of the tests clearly orders them")
    return [f"One factor per test on the held-out prediction (from {min(scales.scales):.2f} "
            f"to {max(scales.scales):.2f}) would remove {scales.share:.0%} of the residual's "
            f"sum of squares{follows}.", ""]


def _source_lines(params: dict[str, float]) -> list[str]:
    """The fitted parameters against their sources' ranges
    (:func:`~cell.diagnosis.cut.causes.candidate.source_checks`): those outside flagged, those no
    source bounds said so."""
    checks = source_checks(params)
    if not checks:
        return []
    lines = ["| parameter | fitted | sources' range | source |", "| --- | --- | --- | --- |"]
    for check in checks:
        low, high = check["range"]
        bounds = "none published" if low is None else f"{low:g} to {high:g}"
        flag = " **outside**" if check["outside"] else ""
        lines.append(f"| `{check['parameter']}` | {check['value']:.4g}{flag} | {bounds} | "
                     f"{check['source']} |")
    return [*lines, ""]
