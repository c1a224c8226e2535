"""Measurement sets: rheological tests on a tissue specimen, read and validated.

A set is a folder with ``specimen.toml`` (the specimen's name, edge lengths and density, an
optional free ``[rig]`` table) and ``tests.csv`` (long format, one row per sample, SI units),
as the project's measured-data spec (``measured-data.md``) defines them: uniaxial, simple shear
and biaxial tests (:mod:`cell.measure.shearbiaxial`), cut tests (mode ``cut``, with ``[block]``
and ``[blade]`` tables: :mod:`cell.measure.cuts`; a set of only cut tests needs no
``[specimen]``). Every fault of the input is an :class:`~cell.errors.InputError` naming the
file and the key, or the line and column, at fault. Reading writes nothing.

Example:
    >>> data = load_measurement_set("assets/measured/beef_round_example")
    >>> test = data.test("c00")
    >>> test.mode, test.angle_deg, round(float(test.strain(data.specimen)[-1]), 3)
    ('compression', 0.0, -0.3)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, cast, get_args

import numpy as np

from cell.config import (
    ANGLE_DEG,
    DENSITY_KG_M3,
    DISPLACEMENT_M,
    FORCE_N,
    LENGTH_M,
    MEASURABLE_STRESS_PA,
    STRESS_PA,
    TIME_S,
    Plausible,
    from_table,
    read_toml,
)
from cell.errors import InputError
from cell.io import CsvTable
from cell.measure.cuts import (
    BLADE_TABLE,
    BLOCK_TABLE,
    CUT_COLUMNS,
    CUT_MODE,
    Blade,
    Block,
    CutTest,
    read_cut_tables,
    read_cut_tests,
)
from cell.measure.shearbiaxial import (
    BIAXIAL_MODE,
    SHEAR_BIAXIAL_COLUMNS,
    SHEAR_MODE,
    BiaxialTest,
    Loads,
    ShearTest,
    freeze_arrays,
    read_biaxial_tests,
    read_shear_tests,
)
from cell.measure.testrows import (
    SPECIMEN_COLUMNS,
    OwnSize,
    check_rows,
    constant,
    own_specimen,
    read_test_rows,
    require_columns,
    rows_of,
)

Mode = Literal["tension", "compression", "relaxation", "cyclic"]
MODES: tuple[str, ...] = get_args(Mode)
"""Uniaxial modes of ``tests.csv``: monotonic ramps, ramp then hold, load/unload cycles."""
_OWN_MODES = (SHEAR_MODE, BIAXIAL_MODE, CUT_MODE)

SPECIMEN_FILE = "specimen.toml"
TESTS_FILE = "tests.csv"
#: The number columns of ``tests.csv`` and the plausible range of each.
_NUMBER_COLUMNS: dict[str, Plausible] = {"angle_deg": ANGLE_DEG, "time_s": TIME_S,
                                         "displacement_m": DISPLACEMENT_M, "force_N": FORCE_N}
#: The columns of one kind of test, needed when the set holds that kind.
_OPTIONAL_COLUMNS = (*_NUMBER_COLUMNS, *CUT_COLUMNS, *SHEAR_BIAXIAL_COLUMNS, *SPECIMEN_COLUMNS)
_TABLES = ("specimen", "rig", BLOCK_TABLE, BLADE_TABLE)


@dataclass(frozen=True)
class Specimen:
    """A tissue sample: a box loaded along its z axis, fibres in its x-z plane.

    Attributes:
        name: free text.
        size_m: (3,) edge lengths along the specimen's x, y and z, m; z is the load axis.
        density_kg_m3: mass density, kg/m^3.
        rig: the ``[rig]`` table of ``specimen.toml`` as read (free text), empty if none.

    Raises:
        InputError: ``size_m`` or ``density_kg_m3`` not finite and > 0, or beyond their
            plausible range (:data:`cell.config.LENGTH_M`, :data:`cell.config.DENSITY_KG_M3`).

    Example:
        >>> cube = Specimen("round-07", (0.01, 0.01, 0.01), 1060.0)
        >>> round(cube.area_m2, 9)
        0.0001
    """

    name: str
    size_m: tuple[float, float, float]
    density_kg_m3: float = 1060.0
    rig: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if len(self.size_m) != 3 or not all(
            math.isfinite(s) and s > 0 for s in self.size_m
        ):
            raise InputError(None, "size_m", f"must be three lengths > 0, got {self.size_m!r}")
        if not (math.isfinite(self.density_kg_m3) and self.density_kg_m3 > 0):
            raise InputError(None, "density_kg_m3", f"must be > 0, got {self.density_kg_m3}")
        for size in self.size_m:
            LENGTH_M.check(size, None, "size_m")
        DENSITY_KG_M3.check(self.density_kg_m3, None, "density_kg_m3")
        object.__setattr__(self, "size_m", tuple(float(s) for s in self.size_m))

    @property
    def area_m2(self) -> float:
        """Initial cross-section across the load axis, m^2."""
        return self.size_m[0] * self.size_m[1]

#: A sample counts as at the machine's zero within this fraction of its test's displacement
#: range (the displacement sensor's noise is far below it, a test's first step far above).
REST_FRACTION = 0.01

@dataclass(frozen=True, eq=False)
class MechanicalTest(OwnSize):
    """One uniaxial test: the displacement history put on the top face and the force there.

    Arrays are read-only, one value per sample, in time order (samples need not be evenly
    spaced). Positive displacement is extension, positive force is tension.

    Attributes:
        test_id: the test's name, unique in its set.
        mode: ``tension``, ``compression``, ``relaxation`` (ramp, then hold) or ``cyclic``.
        angle_deg: angle between the fibres and the load axis, degrees (0 along, 90 across).
        time_s: (n,) time since the start of the test, s, non-decreasing.
        displacement_m: (n,) displacement of the top face along the load axis, m.
        force_n: (n,) axial force on the top face, N.
        specimen_id: the test's specimen, ``""`` when the set does not say.
        size_m: the specimen's own edge lengths along x, y, z, m; None for the set's.

    Example:
        >>> t = np.array([0.0, 1.0, 2.0])
        >>> test = MechanicalTest("t0", "tension", 0.0, t, 1e-4 * t, 0.05 * t)
        >>> test.duration_s, float(test.strain(Specimen("cube", (0.01, 0.01, 0.01)))[-1])
        (2.0, 0.02)
    """

    test_id: str
    mode: Mode
    angle_deg: float
    time_s: np.ndarray
    displacement_m: np.ndarray
    force_n: np.ndarray
    specimen_id: str = ""
    size_m: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        freeze_arrays(self, ("time_s", "displacement_m", "force_n"))

    @property
    def force_N(self) -> np.ndarray:
        """0.1.0's name of :attr:`force_n` (as on a cut test), kept for one release."""
        return self.force_n

    @property
    def duration_s(self) -> float:
        """Time from the first to the last sample, s."""
        return float(self.time_s[-1] - self.time_s[0])

    @property
    def rest_samples(self) -> np.ndarray:
        """Indices of the test's leading samples at the machine's zero, before the top face
        moves (within :data:`REST_FRACTION` of the test's displacement range), where no
        material model carries a force; empty when the test does not start at zero."""
        span = float(np.ptp(self.displacement_m))
        moved = np.abs(self.displacement_m - self.displacement_m[0]) > REST_FRACTION * span
        if span == 0.0 or abs(self.displacement_m[0]) > REST_FRACTION * span:
            return np.arange(0)
        return np.arange(int(np.argmax(moved)) if moved.any() else len(moved))

    # Strain, area and stress are the test's own specimen's where it has one.
    def strain(self, specimen: Specimen) -> np.ndarray:
        """Nominal strain at the samples: displacement over the initial height."""
        return self.displacement_m / self.size_of(specimen)[2]

    def area_m2(self, specimen: Specimen) -> float:
        """Initial cross-section across the load axis, m^2."""
        return self.size_of(specimen)[0] * self.size_of(specimen)[1]

    def stress_pa(self, specimen: Specimen) -> np.ndarray:
        """Nominal stress at the samples, Pa: force over the initial area."""
        return self.force_n / self.area_m2(specimen)

    def loads(self, size_m: tuple[float, float, float]) -> Loads:
        """The measured force by column, with the area it acts on, m^2."""
        return {"force_N": (self.force_n, size_m[0] * size_m[1])}


@dataclass(frozen=True)
class MeasurementSet:
    """A specimen and the tests run on it, as read from a folder.

    Attributes:
        folder: where the set was read from.
        specimen: the specimen of the uniaxial tests; None only in a set of cut tests alone
            that has no ``[specimen]`` table.
        tests: the uniaxial tests, in the order of their first row in ``tests.csv``.
        block: the block of the cut tests (``[block]``), None if the set holds none.
        blade: the blade of the cut tests (``[blade]``), None if the set holds none.
        cut_tests: the cut tests, in the order of their first row, empty for a uniaxial set.
        shear_tests, biaxial_tests: the simple shear and biaxial tests, each in the order of
            its first row (:mod:`cell.measure.shearbiaxial`).

    Example:
        >>> data = load_measurement_set("assets/measured/beef_round_example")
        >>> [t.test_id for t in data.tests][:3]
        ['t00', 't45', 't90']
    """

    folder: Path
    specimen: Specimen | None
    tests: tuple[MechanicalTest, ...]
    block: Block | None = None
    blade: Blade | None = None
    cut_tests: tuple[CutTest, ...] = ()
    shear_tests: tuple[ShearTest, ...] = ()
    biaxial_tests: tuple[BiaxialTest, ...] = ()

    def test(self, test_id: str) -> MechanicalTest:
        """The test named ``test_id`` (KeyError: no such test)."""
        for test in self.tests:
            if test.test_id == test_id:
                return test
        raise KeyError(f"no test {test_id!r} in {self.folder}")


@dataclass(frozen=True)
class _SpecimenTable:
    """The ``[specimen]`` table as written in ``specimen.toml``."""

    name: str
    size_m: tuple[float, float, float]
    density_kg_m3: float = 1060.0

    def __post_init__(self) -> None:
        # Checked here so that from_table names the file and the dotted key.
        Specimen(self.name, self.size_m, self.density_kg_m3)


def load_specimen(path: str | Path) -> Specimen:
    """Read ``specimen.toml``: a ``[specimen]`` table and an optional free ``[rig]`` table.

    Raises:
        InputError: naming the file and the key: missing file, bad TOML, missing or unknown
            table or key, wrong type, a size or density that is not > 0.
    """
    path = Path(path)
    raw = _read_specimen_file(path)
    if "specimen" not in raw:
        raise InputError(path, "specimen", "missing table")
    return _specimen(path, raw)


def _read_specimen_file(path: Path) -> dict[str, Any]:
    """``specimen.toml``'s tables, their names checked."""
    raw = read_toml(path, InputError)
    for key, value in raw.items():
        if key not in _TABLES:
            raise InputError(path, key, f"unknown table (known tables: "
                             f"{', '.join(sorted(_TABLES))})")
        if not isinstance(value, dict):
            raise InputError(path, key, f"expected a table, got {type(value).__name__}")
    return raw


def _specimen(path: Path, raw: dict[str, Any]) -> Specimen:
    """The ``[specimen]`` (and ``[rig]``) of ``specimen.toml``'s tables."""
    table = from_table(_SpecimenTable, raw["specimen"], file=path, section="specimen",
                       error=InputError)
    return Specimen(table.name, table.size_m, table.density_kg_m3, raw.get("rig", {}))


def load_tests(path: str | Path) -> tuple[MechanicalTest, ...]:
    """Read the uniaxial tests of ``tests.csv``: a header line, then one row per sample (see
    the module docstring); rows of other kinds are left out (:func:`load_measurement_set`).
    Read by :func:`cell.io.read_csv`: blank lines and lines starting with ``#`` are skipped,
    extra columns are ignored; a test's rows need not be contiguous but in time order.

    Raises:
        InputError: naming the file and ``line N, column C``: a file that
            :func:`cell.io.read_text` refuses, a missing column, a non-numeric, non-finite or
            implausible value (:mod:`cell.config`), an empty test id, an unknown mode, a mode,
            angle or own specimen (:func:`~cell.measure.testrows.own_specimen`) that changes
            within a test, time going backwards within a test, a test with fewer than 3
            samples, no test at all.
    """
    table, kinds = read_test_rows(Path(path), _OWN_MODES, _OPTIONAL_COLUMNS)
    return _uniaxial_tests(table, kinds[""])


def _uniaxial_tests(table: CsvTable, groups: dict[str, list[int]]
                    ) -> tuple[MechanicalTest, ...]:
    """The uniaxial tests of ``table`` (``groups``: each test's row indices)."""
    if not groups:
        return ()
    require_columns(table, tuple(_NUMBER_COLUMNS))
    table, groups = rows_of(table, groups)
    values = {name: table.numbers(name, plausible.refusal)
              for name, plausible in _NUMBER_COLUMNS.items()}
    return tuple(_test(table, values, test_id, rows) for test_id, rows in groups.items())


def _test(table: CsvTable, values: dict[str, np.ndarray], test_id: str,
          rows: list[int]) -> MechanicalTest:
    """Validate and convert the rows of one test (``rows``: indices into ``table``)."""
    mode = table.cells["mode"][rows[0]]
    row = next((r for r in rows if table.cells["mode"][r] not in (*MODES, *_OWN_MODES)), None)
    if row is not None:
        raise InputError(table.path, table.where(row, "mode"), f"unknown mode "
                         f"{table.cells['mode'][row]!r} (known: {', '.join(MODES + _OWN_MODES)})")
    check_rows(table, test_id, rows, values["time_s"][rows])
    angle = constant(table, "angle_deg", values["angle_deg"][rows], test_id, rows, "deg")
    return MechanicalTest(test_id, cast(Mode, mode), angle, values["time_s"][rows],
                          values["displacement_m"][rows], values["force_N"][rows],
                          *own_specimen(table, test_id, rows))


def load_measurement_set(folder: str | Path) -> MeasurementSet:
    """Read and validate the measurement set in ``folder`` (module docstring).

    Raises:
        InputError: naming the file and the key, or the line and column, at fault (see
            :func:`load_specimen` and :func:`load_tests`), a force that is no plausible
            stress on the specimen's cross-section (:data:`cell.config.STRESS_PA`), forces
            too small to measure anything (:data:`cell.config.MEASURABLE_STRESS_PA`); a missing
            folder is a missing file, a file where the folder should be is refused; no
            ``[specimen]`` where the set holds uniaxial, shear or biaxial tests; the shear
            and biaxial tests' own faults (:mod:`cell.measure.shearbiaxial`).
        CutTestError: bad ``[block]``, ``[blade]`` or cut rows (:mod:`cell.measure.cuts`).

    Example:
        >>> len(load_measurement_set("assets/measured/beef_round_example").tests)
        20
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise InputError(folder, None, f"not a folder: a measurement set is a folder with "
                         f"{SPECIMEN_FILE} and {TESTS_FILE}")
    specimen_path, tests_path = folder / SPECIMEN_FILE, folder / TESTS_FILE
    raw = _read_specimen_file(specimen_path)
    specimen = _specimen(specimen_path, raw) if "specimen" in raw else None
    block, blade = read_cut_tables(specimen_path, raw)
    table, kinds = read_test_rows(tests_path, _OWN_MODES, _OPTIONAL_COLUMNS)
    tests = _uniaxial_tests(table, kinds[""])
    shear = read_shear_tests(table, kinds[SHEAR_MODE])
    biaxial = read_biaxial_tests(table, kinds[BIAXIAL_MODE])
    if (tests or shear or biaxial) and specimen is None:
        raise InputError(specimen_path, "specimen", f"missing table: {TESTS_FILE} holds "
                         "uniaxial, shear or biaxial tests")
    cut_tests = read_cut_tests(table, kinds[CUT_MODE], block, blade, specimen_path)
    if tests or shear or biaxial:
        _check_stress(tests_path, specimen, (*tests, *shear, *biaxial))
    return MeasurementSet(folder, specimen, tests, block, blade, cut_tests, shear, biaxial)


def _check_stress(path: Path, specimen: Specimen,
                  tests: Sequence[MechanicalTest | ShearTest | BiaxialTest]) -> None:
    """The forces as stresses on the faces they load: none beyond
    :data:`cell.config.STRESS_PA`, and the largest at least
    :data:`cell.config.MEASURABLE_STRESS_PA`."""
    peak = 0.0
    for test in tests:
        for column, (force, area) in test.loads(test.size_of(specimen)).items():
            stress = force / area
            row = STRESS_PA.first_outside(stress)
            if row is not None:
                raise InputError(path, f"test {test.test_id}, column {column}",
                                 f"sample {row}: {STRESS_PA.refusal(float(stress[row]))} as "
                                 f"stress on the {area:g} m^2 of the specimen's size_m")
            peak = max(peak, float(np.max(np.abs(stress))))
    if peak < MEASURABLE_STRESS_PA:
        raise InputError(path, "column force_N",
                         f"the largest stress on the specimen is {peak:g} Pa: below "
                         f"{MEASURABLE_STRESS_PA:g} Pa the set measured nothing of a tissue")
