"""Tests repeated under equal conditions, recognised from the tests themselves: their mode,
fibre angle and displacement path (peak strains, each measured column's own included: a biaxial
test's two edges; the rate to the first peak, the hold, the number of load reversals, the
duration), never from their names.

Two tests are repeats when the mode is the same, the angles agree within
:data:`ANGLE_TOLERANCE_DEG` and every feature of the path agrees within
:data:`RELATIVE_TOLERANCE` of the larger of the two (strains also within
:data:`STRAIN_TOLERANCE`, times within :data:`TIME_TOLERANCE` of the longer test). A lab's
repeats are never exact: the machine's displacement is noisy and its sample times differ test
to test, so the features are read where noise barely moves them (the extremes and the times
they are reached).

Example:
    >>> from cell.measure.specimens import load_measurement_set
    >>> data = load_measurement_set("assets/measured/beef_round_example")
    >>> max(len(group) for group in repeat_groups(data.tests, data.specimen))
    1
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell.diagnosis.specimen.planeseries import PlaneSeries, Series
from cell.measure.specimens import Specimen

#: Fibre angles closer than this are one condition, degrees.
ANGLE_TOLERANCE_DEG = 1.0
#: Path features closer than this fraction of the larger are one condition.
RELATIVE_TOLERANCE = 0.05
#: Strains closer than this are one condition (a small peak is noisy in relative terms).
STRAIN_TOLERANCE = 2e-3
#: Times closer than this fraction of the longer test are one condition (samples fall
#: elsewhere in every test).
TIME_TOLERANCE = 0.02
# Share of the peak strain at which the peak counts as reached (noise on a flat top).
_PEAK_SHARE = 0.98
# A turn counts once the strain has come back this share of the peak strain (noise on a
# hold turns it all the time).
_TURN_SHARE = 0.05


@dataclass(frozen=True)
class Condition:
    """What a test does to its specimen, read from its samples.

    Attributes:
        mode: the test's mode.
        angle_deg: its angle to the fibres, degrees.
        peak_strain: the largest nominal strain (tension positive).
        trough_strain: the smallest.
        time_to_peak_s: time at which the largest absolute strain is first (nearly) reached, s.
        hold_s: time spent (nearly) at that strain after it is first reached, s.
        reversals: how many times the displacement turns.
        duration_s: the test's duration, s.
        column_peaks: the largest absolute strain of each measured column (a biaxial test's
            z and x edges; one for a uniaxial test).

    Example:
        >>> from cell.measure.specimens import load_measurement_set
        >>> data = load_measurement_set("assets/measured/beef_round_example")
        >>> Condition.of(data.test("c00"), data.specimen).reversals
        0
    """

    mode: str
    angle_deg: float
    peak_strain: float
    trough_strain: float
    time_to_peak_s: float
    hold_s: float
    reversals: int
    duration_s: float
    column_peaks: tuple[float, ...] = ()

    @classmethod
    def of(cls, test: Series, specimen: Specimen) -> Condition:
        """The condition of ``test`` on ``specimen``."""
        strain = test.strain(specimen)
        time = test.time_s - test.time_s[0]
        size = np.abs(strain)
        peak = float(size.max())
        near = size >= _PEAK_SHARE * peak
        first = int(np.argmax(near))
        # Hold: the run of samples near the peak that starts where the peak is reached.
        last = first + (int(np.argmin(near[first:])) if not near[first:].all()
                        else len(near) - first) - 1
        columns = np.split(size, len(test.columns)) if isinstance(test, PlaneSeries) else [size]
        return cls(test.mode, float(test.angle_deg), float(strain.max()), float(strain.min()),
                   float(time[first]), float(time[last] - time[first]),
                   _reversals(strain, _TURN_SHARE * peak), float(time[-1]),
                   tuple(float(c.max()) for c in columns))

    def matches(self, other: Condition) -> bool:
        """Whether ``other`` is the same condition (module docstring)."""
        if (self.mode != other.mode or self.reversals != other.reversals
                or abs(self.angle_deg - other.angle_deg) > ANGLE_TOLERANCE_DEG):
            return False
        if len(self.column_peaks) != len(other.column_peaks):
            return False
        strains = ((self.peak_strain, other.peak_strain),
                   (self.trough_strain, other.trough_strain),
                   *zip(self.column_peaks, other.column_peaks, strict=True))
        times = ((self.time_to_peak_s, other.time_to_peak_s), (self.hold_s, other.hold_s),
                 (self.duration_s, other.duration_s))
        return (all(_close(a, b, STRAIN_TOLERANCE) for a, b in strains)
                and all(_close(a, b, TIME_TOLERANCE * max(self.duration_s, other.duration_s))
                        for a, b in times))


def _reversals(strain: np.ndarray, threshold: float) -> int:
    """How many times ``strain`` turns by more than ``threshold``."""
    extreme, direction, turns = float(strain[0]), 0.0, 0
    for value in strain:
        if direction == 0.0:
            if abs(value - extreme) > threshold:
                direction, extreme = float(np.sign(value - extreme)), float(value)
        elif (value - extreme) * direction > 0.0:
            extreme = float(value)
        elif abs(value - extreme) > threshold:
            turns, direction, extreme = turns + 1, -direction, float(value)
    return turns


def _close(a: float, b: float, absolute: float) -> bool:
    return abs(a - b) <= max(RELATIVE_TOLERANCE * max(abs(a), abs(b)), absolute)


def repeat_groups(tests: tuple[Series, ...],
                  specimen: Specimen) -> list[list[int]]:
    """The tests grouped by condition (indices into ``tests``, in their order): each test
    joins the first group whose first test it matches."""
    conditions = [Condition.of(t, specimen) for t in tests]
    groups: list[list[int]] = []
    for i, condition in enumerate(conditions):
        group = next((g for g in groups if conditions[g[0]].matches(condition)), None)
        if group is None:
            groups.append([i])
        else:
            group.append(i)
    return groups
