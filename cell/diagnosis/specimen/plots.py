"""One figure per named cause: the tests where the cause shows, measured, and predicted held out
with the cause and without it.

=================================  ============================================================
cause                              panels
=================================  ============================================================
``strain_stiffening``              force against strain of the monotonic ramps
``anisotropy``                     force against strain of the tension ramps, one per angle
``viscoelasticity``                force against strain of ramps at two rates; relaxation holds
``nonlinear_viscoelasticity``      relaxation holds, force over the force at the hold's start
                                   against time in hold, one line per held strain
``tension_compression_asymmetry``  ``|force|`` against ``|strain|``, tension and compression
``plasticity``                     force against strain of the cyclic tests
``force_offset``                   force against strain near zero strain, every test
``specimen_variability``           force against strain of the ramps, each predicted at its
                                   specimen's factor within its group of repeats and at the
                                   population's
=================================  ============================================================

Plots need matplotlib (the ``report`` extra); :mod:`cell.diagnosis.specimen.report` calls
:func:`draw_cause`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from cell.diagnosis.specimen.diagnosis import Diagnosis, Evidence
    from cell.diagnosis.specimen.fitting import ModelFit
    from cell.measure.specimens import MechanicalTest

_WITH, _WITHOUT = "tab:blue", "tab:red"
# Share of a test's largest strain below which a sample counts as near zero.
_NEAR_ZERO = 0.2


def _ramp_like(test: MechanicalTest) -> bool:
    return test.mode in ("tension", "compression")


def _panels(cause: str, tests: tuple[MechanicalTest, ...]) -> list[tuple[str, list[int]]]:
    """(kind of panel, indices of its tests) for ``cause``."""
    every = list(range(len(tests)))
    ramps = [i for i in every if _ramp_like(tests[i])]
    holds = [i for i in every if tests[i].mode == "relaxation"]
    if cause == "anisotropy":
        return [("strain", [i for i in ramps if tests[i].mode == "tension"] or ramps)]
    if cause == "viscoelasticity":
        return [("strain", ramps), ("time", holds)]
    if cause == "nonlinear_viscoelasticity":
        return [("relaxed", holds or every)]
    if cause == "tension_compression_asymmetry":
        return [("magnitude", ramps or every)]
    if cause == "plasticity":
        return [("strain", [i for i in every if tests[i].mode == "cyclic"] or every)]
    if cause == "force_offset":
        return [("near_zero", every)]
    return [("strain", ramps or every)]


def _hold_start(test: MechanicalTest) -> int:
    """Index of the first sample at the test's largest |displacement|."""
    return int(np.argmax(np.abs(test.displacement_m)))


def _curve(kind: str, test: MechanicalTest, force: np.ndarray, strain: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) of one test in a panel of ``kind``."""
    if kind == "time":
        start = _hold_start(test)
        return test.time_s[start:] - test.time_s[start], force[start:]
    if kind == "relaxed":
        start = _hold_start(test)
        return (test.time_s[start:] - test.time_s[start],
                force[start:] / (test.force_n[start] or 1.0))
    if kind == "magnitude":
        return np.abs(strain), np.abs(force)
    if kind == "near_zero":
        near = np.abs(strain) <= _NEAR_ZERO * max(float(np.abs(strain).max()), 1e-12)
        return strain[near], force[near]
    return strain, force


_LABELS = {"strain": ("nominal strain", "force (N)"), "time": ("time in hold (s)", "force (N)"),
           "relaxed": ("time in hold (s)", "force / force at the hold's start"),
           "magnitude": ("|nominal strain|", "|force| (N)"),
           "near_zero": ("nominal strain", "force (N)")}


def _draw_panel(ax: Axes, kind: str, rows: list[int], diagnosis: Diagnosis,
                fits: tuple[ModelFit, ModelFit]) -> None:
    data = diagnosis.measurements
    for k in rows:
        test = diagnosis.series[k]
        strain = test.strain(data.specimen)
        x, y = _curve(kind, test, test.force_n, strain)
        ax.plot(x, y, ".", markersize=2.5, alpha=0.6,
                label=f"{test.test_id} ({test.mode}, {test.angle_deg:g}°)")
        for fit, style, color in zip(fits, ("-", "--"), (_WITH, _WITHOUT), strict=True):
            x, y = _curve(kind, test, fit.heldout_force_n[k], strain)
            ax.plot(x, y, style, color=color, linewidth=1.0)
    ax.set_xlabel(_LABELS[kind][0])
    ax.set_ylabel(_LABELS[kind][1])
    ax.legend(fontsize=7, markerscale=3)


def draw_cause(figure: Figure, diagnosis: Diagnosis, evidence: Evidence) -> Figure:
    """The figure of one named cause (module docstring): measured points, the held-out
    prediction with the cause (solid blue) and without it (dashed red)."""
    tests = diagnosis.series
    panels = ([(kind, rows) for kind, rows in _panels(evidence.cause, tests) if rows]
              or [("strain", list(range(len(tests))))])
    figure.set_size_inches(5.5 * len(panels), 4.2)
    axes = figure.subplots(1, len(panels), squeeze=False).ravel()
    for ax, (kind, rows) in zip(axes, panels, strict=True):
        with_it = diagnosis.extended if evidence.with_fit is None else evidence.with_fit
        _draw_panel(ax, kind, rows, diagnosis, (with_it, evidence.without))
    figure.suptitle(
        f"{evidence.cause}: held-out RMSE {evidence.heldout_rmse_with_n:.3g} N with it (solid "
        f"blue), {evidence.heldout_rmse_without_n:.3g} N without (dashed red); it improves "
        f"{evidence.improved_fraction:.0%} of the tests", fontsize=10)
    return figure
