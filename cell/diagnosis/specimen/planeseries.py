"""Shear and biaxial tests in a specimen diagnosis: each one series of the fit, diagnosed with
the uniaxial tests of the same tissue, and each cause's evidence per mode.

A :class:`PlaneSeries` is a simple shear or biaxial test
(:mod:`cell.measure.shearbiaxial`) as the fit sees a test: its measured force columns one after
another (``force_n``: shear force, then the normal force where measured; the z edges' force,
then the x edges'), with the times, displacements and strains repeated for each column, and
the forward model that gives the same columns (:mod:`cell.diagnosis.specimen.shearbiaxial`:
the lattice with the test's components of F prescribed). The fit scales E and the offset over
every series at once, so one material explains the uniaxial, shear and biaxial tests together.

Example:
    >>> from cell.measure.shearbiaxial import ShearTest
    >>> from cell.measure.specimens import Specimen
    >>> t = np.linspace(0.0, 1.0, 4)
    >>> series = PlaneSeries(ShearTest("s1", "fs", t, 1e-4 * t, 0.01 * t, -0.001 * t),
    ...                      (0.01, 0.01, 0.01))
    >>> series.mode, series.force_n.shape, series.subset(np.array([0, 3])).force_n.shape
    ('shear fs', (8,), (4,))
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from cell.diagnosis.specimen.shearbiaxial import simulate_biaxial, simulate_shear
from cell.diagnosis.specimen.solve import SpecimenLattice, simulate_tests
from cell.measure.shearbiaxial import BIAXIAL_MODE, SHEAR_MODE, BiaxialTest, ShearTest
from cell.measure.specimens import MeasurementSet, MechanicalTest, Specimen
from cell.tissue.material import MassSpringMaterial

#: Each kind of test's arrays with one value per sample.
_SAMPLE_ARRAYS = ("time_s", "displacement_m", "displacement_x_m", "force_n", "normal_force_n",
                  "force_x_n")


@dataclass(frozen=True, eq=False)
class PlaneSeries:
    """A shear or biaxial test as one series of a specimen fit (module docstring).

    Attributes:
        test: the shear or biaxial test.
        size_m: the edge lengths it ran on (its own, else the set's specimen's), m.

    The module's example makes one.
    """

    test: ShearTest | BiaxialTest
    size_m: tuple[float, float, float]

    @property
    def test_id(self) -> str:
        """The test's id."""
        return self.test.test_id

    @property
    def mode(self) -> str:
        """``shear`` and the shear plane (``shear fs``: each plane its own condition), or
        ``biaxial``."""
        if isinstance(self.test, ShearTest):
            return f"{SHEAR_MODE} {self.test.shear_plane}"
        return BIAXIAL_MODE

    @property
    def angle_deg(self) -> float:
        """The fibres' angle from z in a biaxial sheet, degrees; 0 in shear (the shear plane
        says where the fibres lie)."""
        return float(getattr(self.test, "angle_deg", 0.0))

    @property
    def columns(self) -> tuple[str, ...]:
        """The measured force columns, in the order of :attr:`force_n`."""
        return tuple(self.test.loads(self.size_m))

    @property
    def force_n(self) -> np.ndarray:
        """The measured forces, column after column, N."""
        return np.concatenate([force for force, _ in self.test.loads(self.size_m).values()])

    @property
    def time_s(self) -> np.ndarray:
        """The sample times, once per column, s."""
        return np.tile(self.test.time_s, len(self.columns))

    @property
    def displacement_m(self) -> np.ndarray:
        """The driving displacement (the top plate's, the z edges'), once per column, m."""
        return np.tile(self.test.displacement_m, len(self.columns))

    @property
    def duration_s(self) -> float:
        """Time from the first to the last sample, s."""
        return float(self.test.time_s[-1] - self.test.time_s[0])

    @property
    def rest_samples(self) -> np.ndarray:
        """None: a load-cell offset is judged on the uniaxial tests' rest samples."""
        return np.arange(0)

    def strain(self, specimen: Specimen) -> np.ndarray:
        """A nominal strain per sample of each column: half the amount of shear (the
        principal strain of a small shear), or the column's own edge strain (biaxial)."""
        if isinstance(self.test, ShearTest):
            return np.tile(self.test.gamma(self.size_m) / 2.0, len(self.columns))
        return np.concatenate(self.test.strains(self.size_m).T)

    def subset(self, rows: np.ndarray) -> PlaneSeries:
        """The same test at its samples ``rows`` (indices into the test's own samples)."""
        arrays = {name: getattr(self.test, name)[rows] for name in _SAMPLE_ARRAYS
                  if getattr(self.test, name, None) is not None}
        return PlaneSeries(replace(self.test, **arrays), self.size_m)

    def simulated(self, specimen: Specimen, material: MassSpringMaterial,
                  lattice: SpecimenLattice) -> np.ndarray:
        """The forces ``material`` gives in the measured columns, column after column, N."""
        test = replace(self.test, size_m=self.size_m)
        simulate = simulate_shear if isinstance(test, ShearTest) else simulate_biaxial
        run = simulate(test, specimen, material, lattice)  # type: ignore[arg-type]
        return np.concatenate([run.force_n[column] for column in self.columns])


Series = MechanicalTest | PlaneSeries


def fitted_series(measurements: MeasurementSet) -> tuple[Series, ...]:
    """The tests a specimen diagnosis fits: the uniaxial ones, then each shear and each
    biaxial test as a :class:`PlaneSeries` (a uniaxial set's tests, unchanged)."""
    specimen = measurements.specimen
    return (*measurements.tests,
            *(PlaneSeries(t, t.size_of(specimen))
              for t in (*measurements.shear_tests, *measurements.biaxial_tests)))


def series_forces(tests: Sequence[Series], specimen: Specimen, material: MassSpringMaterial,
                  lattice: SpecimenLattice) -> list[np.ndarray]:
    """Each test's simulated force, N: the uniaxial ones in one
    :func:`~cell.diagnosis.specimen.solve.simulate_tests` call, as a uniaxial set's are.

    Raises:
        MaterialError, DivergenceError: as :func:`simulate_tests`.
    """
    uniaxial = iter(simulate_tests([t for t in tests if isinstance(t, MechanicalTest)],
                                   specimen, material, lattice))
    return [test.simulated(specimen, material, lattice) if isinstance(test, PlaneSeries)
            else next(uniaxial).force_n for test in tests]


def per_mode_rmse(heldout: Sequence[np.ndarray], tests: Sequence[Series]
                  ) -> dict[str, float]:
    """Held-out RMSE over each mode's tests, N, by mode (each shear plane its own) in the order
    first met."""
    modes = list(dict.fromkeys(t.mode for t in tests))
    return {mode: float(np.sqrt(np.mean(np.concatenate(
        [(h - t.force_n) ** 2 for h, t in zip(heldout, tests, strict=True)
         if t.mode == mode])))) for mode in modes}
