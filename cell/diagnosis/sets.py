"""Diagnosis of a measurement set that may hold uniaxial tests, cut tests or both, in one run.

The two kinds share no parameter (the uniaxial tests set the springs, the cut tests the cutting
model), so each part is diagnosed on its own tests (the shear and biaxial tests with the
uniaxial ones: they set the same springs)
(:func:`cell.diagnosis.specimen.diagnosis.diagnose`,
:func:`cell.diagnosis.cut.search.diagnose_cuts`) and the results are joined: the causes of both
catalogues, one extended material (the fitted springs with the fitted cutting model as its
``[cutting]`` table; for a set of cut tests alone, the default beef's springs), and the JSON of the
diagnosis contract (docs/measured-data.md).

The JSON: for a set with uniaxial tests, the uniaxial diagnosis's own (unchanged for a set
without cut tests) with ``causes`` joined and the cut tests' diagnosis under ``cut``; for a set
of cut tests alone, the cut tests' diagnosis at the top and under ``cut`` alike.

Usage::

    result = diagnose_set(load_measurement_set("some-set"))
    result.causes, result.material()
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from cell.diagnosis.cut.causes import source_checks
from cell.diagnosis.cut.search import CutDiagnosis, diagnose_cuts
from cell.diagnosis.engine.determined import shown
from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.specimen.causes import UNEXPLAINED
from cell.diagnosis.specimen.diagnosis import Diagnosis, diagnose
from cell.errors import DiagnosisError
from cell.measure.specimens import MeasurementSet
from cell.tissue.material import MassSpringMaterial, default_meat


@dataclass(frozen=True, eq=False)
class SetDiagnosis:
    """What :func:`diagnose_set` found.

    Attributes:
        measurements: the set.
        uniaxial: the diagnosis of its uniaxial tests, None when it has none.
        cut: the diagnosis of its cut tests, None when it has none.
    """

    measurements: MeasurementSet
    uniaxial: Diagnosis | None
    cut: CutDiagnosis | None

    @property
    def causes(self) -> tuple[str, ...]:
        """The uniaxial causes, then the cut ones, ``unexplained`` last if either part has it."""
        parts = [p.causes for p in (self.uniaxial, self.cut) if p is not None]
        named = tuple(c for causes in parts for c in causes if c != UNEXPLAINED)
        return named + ((UNEXPLAINED,) if any(UNEXPLAINED in c for c in parts) else ())

    def material(self) -> MassSpringMaterial:
        """The extended material: the uniaxial fit's springs (the default beef's without
        uniaxial tests) with the cut fit's cutting model (the springs' own without cut tests)."""
        springs = default_meat() if self.uniaxial is None else self.uniaxial.extended.material
        if self.cut is None:
            return springs
        return replace(springs, cutting=self.cut.extended.cutting)

    def material_comment(self) -> str:
        """The comment lines on top of the extended material's file."""
        lines = [] if self.uniaxial is None else [self.uniaxial.material_comment()]
        if self.cut is not None:
            extended = self.cut.extended
            lines.append(
                f"Cutting model fitted to the {len(extended.heldout_force_n)} cut tests of "
                f"{self.measurements.folder.name}: {extended.model.name}; causes: "
                f"{', '.join(self.cut.causes) or 'none'}; held-out RMSE "
                f"{shown(extended.heldout_rmse_n, '.4g')} N (baseline "
                f"{shown(self.cut.baseline.heldout_rmse_n, '.4g')} N).")
            if extended.model.has_offset:
                lines.append("The blade's sensor read "
                             f"{[round(float(v), 4) for v in extended.offset_n]} N in air: a "
                             "rig effect, not part of this material.")
            if self.uniaxial is None:
                lines.append("No uniaxial tests: the springs are the default beef's.")
        return "\n".join(lines)

    def summary(self) -> str:
        """One line per part: causes and held-out errors."""
        lines = []
        data = self.measurements
        springs = ("uniaxial" if not (data.shear_tests or data.biaxial_tests)
                   else "uniaxial, shear and biaxial")
        for kind, part in ((springs, self.uniaxial), ("cut", self.cut)):
            if part is not None:
                lines.append(f"{kind}: causes {', '.join(part.causes) or 'none'}; held-out "
                             f"RMSE {shown(part.baseline.heldout_rmse_n, '.4g')} N -> "
                             f"{shown(part.extended.heldout_rmse_n, '.4g')} N (gain "
                             f"{shown(part.gain, '.3f')}, "
                             f"noise {part.noise_n:.3g} N)")
        if self.cut is not None:
            lines += [f"cut: {c['parameter']} = {c['value']:.4g} outside its sources' range "
                      f"{c['range']} ({c['source']})"
                      for c in source_checks(self.cut.extended.params) if c["outside"]]
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        """The contract's JSON (module docstring)."""
        cut = None if self.cut is None else self.cut.to_json()
        top = dict(cut) if self.uniaxial is None else self.uniaxial.to_json()
        top["causes"] = list(self.causes)
        if cut is not None:
            top["cut"] = cut
        return top


def diagnose_set(measurements: MeasurementSet, params: DiagnosisParams | None = None,
                 on_fit: Callable[[int], object] | None = None) -> SetDiagnosis:
    """Diagnose every test of ``measurements``, each kind on its own (module docstring);
    ``on_fit`` is called with 1 after each fit (progress).

    Raises:
        DiagnosisError: a set with no test, or a specimen diagnosis (uniaxial, shear and
            biaxial tests together) that cannot run
            (:func:`cell.diagnosis.specimen.diagnosis.diagnose`).
    """
    params = DiagnosisParams() if params is None else params
    specimen_tests = (*measurements.tests, *measurements.shear_tests,
                      *measurements.biaxial_tests)
    if not specimen_tests and not measurements.cut_tests:
        raise DiagnosisError(measurements.folder, None, "the set holds no test")
    uniaxial = diagnose(measurements, params, on_fit) if specimen_tests else None
    cut = None
    if measurements.cut_tests:
        cut = diagnose_cuts(measurements.block, measurements.blade, measurements.cut_tests,
                            params, on_fit=on_fit)
    return SetDiagnosis(measurements, uniaxial, cut)
