"""The tests a lab could run next (:class:`CandidateTest`), drawn up from a measurement set's
own strains and rates (:func:`candidate_tests`), for :mod:`cell.diagnosis.specimen.suggest`
to simulate.

The grid: ramps in tension and in compression along, oblique (45 degrees) and across the
fibres, at the set's rate and ten times it; ramp-and-holds in tension and in compression,
along and across, to the set's strain and half of it; load/unload cycles (two) in tension and
in compression, along and across. A set with no test in tension (or compression) gets the
strain of the other sign; a set with no ramp, a rate of 1 %/s.

Example:
    >>> test = CandidateTest("relaxation", 90.0, -0.1, 0.05, hold_s=60.0)
    >>> test.description
    'ramp to -0.10 at 5 %/s, then a 60 s hold, 90 deg to the fibres'
    >>> len(test.plan("next").time_s)
    60
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from cell.measure.protocols import TestPlan, cyclic, ramp, relaxation
from cell.measure.specimens import MeasurementSet, MechanicalTest, Specimen

#: Samples of a candidate ramp, of a hold's ramp and of its hold, and of two cycles (every
#: turning point sampled).
RAMP_SAMPLES, HOLD_RAMP_SAMPLES, HOLD_SAMPLES, CYCLE_SAMPLES = 60, 20, 40, 81
#: The angles to the fibres the candidates are cut at, degrees.
ANGLES_DEG = (0.0, 45.0, 90.0)
#: A hold's ramp is this many times the set's rate, and so is the fast ramp.
FAST = 10.0
#: The rate a set with no ramp is given, 1/s, and the hold a set with no hold is given, s.
DEFAULT_RATE_PER_S, DEFAULT_HOLD_S = 0.01, 100.0
_CYCLES = 2


@dataclass(frozen=True)
class CandidateTest:
    """A test a lab could run: mode, angle to the fibres, peak nominal strain, strain rate
    and, for a ramp-and-hold, the hold.

    Attributes:
        mode: ``tension``, ``compression``, ``relaxation`` or ``cyclic``.
        angle_deg: angle between the fibres and the load axis, degrees.
        strain: the peak nominal strain (negative: compression).
        rate_per_s: the strain rate of the ramps, 1/s.
        hold_s: the hold after the ramp, s (relaxation only, else 0).

    Example:
        >>> CandidateTest("cyclic", 0.0, 0.1, 0.01).description
        '2 cycles 0 to +0.10 and back at 1 %/s, 0 deg to the fibres'
    """

    mode: str
    angle_deg: float
    strain: float
    rate_per_s: float
    hold_s: float = 0.0

    def plan(self, test_id: str) -> TestPlan:
        """The test's displacement path and sample times (:mod:`cell.measure.protocols`)."""
        if self.mode == "relaxation":
            plan = relaxation(test_id, self.angle_deg, self.strain, self.rate_per_s,
                              self.hold_s, HOLD_RAMP_SAMPLES, HOLD_SAMPLES)
        elif self.mode == "cyclic":
            plan = cyclic(test_id, self.angle_deg, self.strain, self.rate_per_s, _CYCLES,
                          CYCLE_SAMPLES)
        else:
            plan = ramp(test_id, self.mode, self.angle_deg, self.strain, self.rate_per_s,
                        RAMP_SAMPLES)
        return plan

    @property
    def description(self) -> str:
        """One line: the path and the angle to the fibres."""
        return f"{self.plan('next').description}, {self.angle_deg:g} deg to the fibres"

    def mechanical_test(self, specimen: Specimen, test_id: str = "next") -> MechanicalTest:
        """The test on ``specimen`` with no force measured yet (zeros), to be simulated."""
        plan = self.plan(test_id)
        return MechanicalTest(test_id, self.mode, self.angle_deg, plan.time_s,
                              plan.strain() * specimen.size_m[2], np.zeros(len(plan.time_s)))

    def to_json(self) -> dict[str, Any]:
        """The test as the suggestion's JSON gives it."""
        return {"mode": self.mode, "angle_deg": self.angle_deg, "strain": self.strain,
                "rate_per_s": self.rate_per_s, "hold_s": self.hold_s,
                "description": self.description}


def _rate_per_s(test: MechanicalTest, specimen: Specimen) -> float | None:
    """The strain rate of a test's first ramp: its peak strain over the time to reach it."""
    strain = np.abs(test.strain(specimen))
    peak = int(np.argmax(strain))
    elapsed = float(test.time_s[peak] - test.time_s[0])
    return float(strain[peak]) / elapsed if elapsed > 0 and strain[peak] > 0 else None


def _round(value: float) -> float:
    """``value`` to two significant digits (a rate or a hold a lab would set)."""
    return float(f"{value:.2g}")


def candidate_tests(measurements: MeasurementSet) -> list[CandidateTest]:
    """The candidate tests for ``measurements`` (module docstring)."""
    specimen = measurements.specimen
    strains = np.concatenate([t.strain(specimen) for t in measurements.tests])
    tension, compression = float(strains.max()), float(-strains.min())
    tension = tension if tension > 1e-3 else compression
    compression = compression if compression > 1e-3 else tension
    rates = [r for t in measurements.tests if t.mode in ("tension", "compression")
             and (r := _rate_per_s(t, specimen)) is not None]
    rate = _round(float(np.median(rates))) if rates else DEFAULT_RATE_PER_S
    holds = [t.duration_s for t in measurements.tests if t.mode == "relaxation"]
    hold = _round(float(np.median(holds))) if holds else DEFAULT_HOLD_S
    tension, compression = round(tension, 2), round(compression, 2)
    tests = [CandidateTest(mode, angle, peak, speed)
             for mode, peak in (("tension", tension), ("compression", -compression))
             for angle in ANGLES_DEG for speed in (rate, FAST * rate)]
    tests += [CandidateTest("relaxation", angle, peak * level, FAST * rate, hold)
              for peak in (tension, -compression) for angle in (0.0, 90.0)
              for level in (0.5, 1.0)]
    tests += [CandidateTest("cyclic", angle, peak, rate)
              for peak in (tension, -compression) for angle in (0.0, 90.0)]
    return tests
