"""Simple shear and biaxial tests: what each prescribes and measures, and their rows' reader.

Both are read from a set's ``tests.csv`` beside the uniaxial tests (measured-data.md gives the
columns, signs and frames):

- ``shear``: the specimen glued between two plates normal to its z axis, the bottom one held,
  the top one moved along x by ``displacement_m`` at a fixed gap: the amount of shear is
  ``gamma = displacement_m / size_z``. ``force_N`` is the force on the top plate along x, and
  ``normal_force_N`` (optional) the force on it along z, positive pulling the plates apart
  from the specimen (tension, as in the uniaxial modes). ``shear_plane`` names the tissue's
  axes in the plates' frame, as Sommer et al. (2015) do: two of ``f`` (fibres), ``s``
  (sheets), ``n`` (normal), the first along the plates' normal z, the second along the shear
  x; the third is along y.
- ``biaxial``: a sheet in the specimen's x-z plane (its thickness along y), stretched along z
  by ``displacement_m`` and along x by ``displacement_x_m`` (positive: extension), its edges free
  to slide; ``force_N`` is the force along z on the z edges, ``force_x_N`` the force along x on
  the x edges (positive pulls); ``angle_deg`` the fibres' angle from z in the sheet's plane, as
  in the uniaxial modes.

Example:
    >>> t = np.array([0.0, 1.0, 2.0])
    >>> test = ShearTest("fs1", "fs", t, 1e-3 * t, 0.01 * t)
    >>> test.gamma((0.01, 0.01, 0.005)).tolist(), test.fibre_axis
    ([0.0, 0.2, 0.4], 2)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar, Literal, cast, get_args

import numpy as np

from cell.config import ANGLE_DEG, DISPLACEMENT_M, FORCE_N, TIME_S, Plausible
from cell.errors import InputError
from cell.io import CsvTable
from cell.measure.testrows import (
    OwnSize,
    check_rows,
    constant,
    own_specimen,
    require_columns,
    rows_of,
)

ShearPlane = Literal["fs", "fn", "sf", "sn", "nf", "ns"]
SHEAR_PLANES: tuple[str, ...] = get_args(ShearPlane)
"""The six shear modes of an orthotropic tissue: the axis normal to the plates, then the axis
of shear (``f`` fibres, ``s`` sheets, ``n`` their normal)."""
SHEAR_MODE, BIAXIAL_MODE = "shear", "biaxial"
#: The columns each mode reads besides ``test_id``, ``mode`` and ``time_s``, and their ranges.
_SHEAR_NUMBERS: dict[str, Plausible] = {"displacement_m": DISPLACEMENT_M, "force_N": FORCE_N}
_BIAXIAL_NUMBERS: dict[str, Plausible] = {
    "angle_deg": ANGLE_DEG, "displacement_m": DISPLACEMENT_M, "force_N": FORCE_N,
    "displacement_x_m": DISPLACEMENT_M, "force_x_N": FORCE_N}
#: Every column either mode reads that the uniaxial modes do not.
SHEAR_BIAXIAL_COLUMNS = ("shear_plane", "normal_force_N", "displacement_x_m", "force_x_N")
Loads = dict[str, tuple[np.ndarray, float]]
"""Each measured force's column: the force, N, and the area it acts on, m^2."""


def freeze_arrays(test: object, names: Sequence[str]) -> None:
    """Each of ``test``'s (a frozen dataclass) attributes ``names`` that is set as a read-only
    float array."""
    for name in names:
        if getattr(test, name) is not None:
            values = np.array(getattr(test, name), dtype=float)
            values.setflags(write=False)
            object.__setattr__(test, name, values)


def _sample_values(table: CsvTable, groups: dict[str, list[int]],
                   numbers: dict[str, Plausible], also: Sequence[str] = ()
                   ) -> tuple[CsvTable, dict[str, list[int]], dict[str, np.ndarray]]:
    """The columns ``also`` and ``numbers`` required, the table and ``groups`` as
    :func:`rows_of` gives them, and the time and each of ``numbers`` read as plausible
    numbers."""
    require_columns(table, (*also, *numbers))
    table, groups = rows_of(table, groups)
    return table, groups, {name: table.numbers(name, plausible.refusal)
                           for name, plausible in {"time_s": TIME_S, **numbers}.items()}


@dataclass(frozen=True, eq=False)
class ShearTest(OwnSize):
    """One simple shear test (module docstring): the top plate's displacement along x and the
    forces on it. Arrays are read-only, one value per sample, in time order.

    Attributes:
        test_id: the test's name, unique in its set.
        shear_plane: one of :data:`SHEAR_PLANES`: the tissue's axes along z and x.
        time_s: (n,) time since the start of the test, s.
        displacement_m: (n,) the top plate's displacement along x, m.
        force_n: (n,) the force on the top plate along x, N.
        normal_force_n: (n,) the force on it along z, N (+ pulls), None when not measured.
        specimen_id: the test's specimen, ``""`` when the set does not say.
        size_m: the specimen's own edge lengths along x, y, z, m; None for the set's.

    Example:
        >>> t = np.array([0.0, 1.0, 2.0])
        >>> test = ShearTest("sn1", "sn", t, 1e-3 * t, 0.01 * t, -0.001 * t, "S2")
        >>> test.fibre_axis, test.loads((0.01, 0.01, 0.01))["normal_force_N"][1]
        (1, 0.0001)
    """

    mode: ClassVar[str] = SHEAR_MODE
    test_id: str
    shear_plane: ShearPlane
    time_s: np.ndarray
    displacement_m: np.ndarray
    force_n: np.ndarray
    normal_force_n: np.ndarray | None = None
    specimen_id: str = ""
    size_m: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if self.shear_plane not in SHEAR_PLANES:
            raise InputError(None, "shear_plane", f"must be one of {', '.join(SHEAR_PLANES)}, "
                             f"got {self.shear_plane!r}")
        freeze_arrays(self, ("time_s", "displacement_m", "force_n", "normal_force_n"))

    @property
    def fibre_axis(self) -> int:
        """The specimen axis along the fibres: 2 (z) for ``f?``, 0 (x) for ``?f``, else 1."""
        return self.axis_of("f")

    @property
    def sheet_axis(self) -> int:
        """The specimen axis along the sheets, as :attr:`fibre_axis` for ``s``."""
        return self.axis_of("s")

    def axis_of(self, tissue_axis: str) -> int:
        """The specimen axis (0 x, 1 y, 2 z) along the tissue's ``f``, ``s`` or ``n``."""
        plane = self.shear_plane
        return 2 if plane[0] == tissue_axis else 0 if plane[1] == tissue_axis else 1

    def gamma(self, size_m: Sequence[float]) -> np.ndarray:
        """The amount of shear at the samples: displacement over the height ``size_m[2]``."""
        return self.displacement_m / size_m[2]

    def loads(self, size_m: Sequence[float]) -> Loads:
        """The measured forces by column, each with the plates' area (x by y)."""
        area = size_m[0] * size_m[1]
        forces = {"force_N": self.force_n, "normal_force_N": self.normal_force_n}
        return {name: (force, area) for name, force in forces.items() if force is not None}


@dataclass(frozen=True, eq=False)
class BiaxialTest(OwnSize):
    """One biaxial test (module docstring): the stretches put on a sheet in the x-z plane and
    the forces on its edges. Arrays are read-only, one value per sample, in time order.

    Attributes:
        test_id: the test's name, unique in its set.
        angle_deg: angle between the fibres and z, in the sheet's plane, degrees.
        time_s: (n,) time since the start of the test, s.
        displacement_m: (n,) the z edges' displacement along z, m (+ extends).
        displacement_x_m: (n,) the x edges' displacement along x, m (+ extends).
        force_n: (n,) the force on the z edges along z, N (+ pulls).
        force_x_n: (n,) the force on the x edges along x, N (+ pulls).
        specimen_id: the test's specimen, ``""`` when the set does not say.
        size_m: the specimen's own edge lengths along x, y, z, m; None for the set's.

    Example:
        >>> t = np.array([0.0, 1.0, 2.0])
        >>> test = BiaxialTest("b1", 0.0, t, 1e-3 * t, 5e-4 * t, 0.1 * t, 0.05 * t)
        >>> test.strains((0.02, 0.002, 0.02))[-1].tolist()
        [0.1, 0.05]
    """

    mode: ClassVar[str] = BIAXIAL_MODE
    test_id: str
    angle_deg: float
    time_s: np.ndarray
    displacement_m: np.ndarray
    displacement_x_m: np.ndarray
    force_n: np.ndarray
    force_x_n: np.ndarray
    specimen_id: str = ""
    size_m: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        freeze_arrays(self, ("time_s", "displacement_m", "displacement_x_m", "force_n",
                             "force_x_n"))

    def strains(self, size_m: Sequence[float]) -> np.ndarray:
        """(n, 2) nominal strains at the samples: along z, then along x."""
        return np.stack([self.displacement_m / size_m[2],
                         self.displacement_x_m / size_m[0]], axis=1)

    def loads(self, size_m: Sequence[float]) -> Loads:
        """The measured forces by column, each with its edges' area (x by y for z, y by z
        for x)."""
        return {"force_N": (self.force_n, size_m[0] * size_m[1]),
                "force_x_N": (self.force_x_n, size_m[1] * size_m[2])}


def read_shear_tests(table: CsvTable, groups: dict[str, list[int]]) -> tuple[ShearTest, ...]:
    """The shear tests of ``table`` (``groups``: each test's row indices, its first row's mode
    ``shear``).

    Raises:
        CsvError: a missing column, a value that is no finite plausible number.
        InputError: naming the line and column: a mode, shear plane or specimen that changes
            within a test, an unknown shear plane, an ``angle_deg`` given (the shear plane says
            where the fibres lie), a normal force on some samples of a test only, fewer than 3
            samples, time going backwards.
    """
    if not groups:
        return ()
    table, groups, values = _sample_values(table, groups, _SHEAR_NUMBERS, ("shear_plane",))
    tests = []
    for test_id, rows in groups.items():
        check_rows(table, test_id, rows, values["time_s"][rows])
        plane = _text(table, "shear_plane", test_id, rows)
        if plane not in SHEAR_PLANES:
            raise InputError(table.path, table.where(rows[0], "shear_plane"),
                             f"unknown shear plane {plane!r} (known: {', '.join(SHEAR_PLANES)})")
        angles = table.cells.get("angle_deg")
        given = next((row for row in rows if angles and angles[row]), None)
        if given is not None:
            raise InputError(table.path, table.where(given, "angle_deg"), "a shear test's "
                             "fibres lie as its shear_plane says: leave angle_deg empty")
        tests.append(ShearTest(test_id, cast(ShearPlane, plane), values["time_s"][rows],
                               values["displacement_m"][rows], values["force_N"][rows],
                               _normal_force(table, test_id, rows),
                               *own_specimen(table, test_id, rows)))
    return tuple(tests)


def _text(table: CsvTable, column: str, test_id: str, rows: Sequence[int]) -> str:
    """The text of ``column`` that one test keeps throughout."""
    cells = [table.cells[column][row] for row in rows]
    changed = next((i for i, cell in enumerate(cells) if cell != cells[0]), None)
    if changed is not None:
        raise InputError(table.path, table.where(rows[changed], column), f"test {test_id!r} "
                         f"changes {column} from {cells[0]!r} to {cells[changed]!r}")
    return cells[0]


def _normal_force(table: CsvTable, test_id: str, rows: Sequence[int]) -> np.ndarray | None:
    """A shear test's normal force, None where the test (or the file) has none."""
    cells = [table.cells.get("normal_force_N", [""] * len(table.lines))[row] for row in rows]
    if not any(cells):
        return None
    empty = next((i for i, cell in enumerate(cells) if not cell), None)
    if empty is not None:
        raise InputError(table.path, table.where(rows[empty], "normal_force_N"),
                         f"empty, where test {test_id!r} gives a normal force on other samples")
    return CsvTable(table.path, tuple(table.lines[row] for row in rows),
                    {"normal_force_N": cells}).numbers("normal_force_N", FORCE_N.refusal)


def read_biaxial_tests(table: CsvTable, groups: dict[str, list[int]]
                       ) -> tuple[BiaxialTest, ...]:
    """The biaxial tests of ``table`` (``groups``: each test's row indices, its first row's
    mode ``biaxial``).

    Raises:
        CsvError: a missing column, a value that is no finite plausible number.
        InputError: naming the line and column: a mode, angle or specimen that changes within
            a test, fewer than 3 samples, time going backwards.
    """
    if not groups:
        return ()
    table, groups, values = _sample_values(table, groups, _BIAXIAL_NUMBERS)
    tests = []
    for test_id, rows in groups.items():
        check_rows(table, test_id, rows, values["time_s"][rows])
        angle = constant(table, "angle_deg", values["angle_deg"][rows], test_id, rows, "deg")
        tests.append(BiaxialTest(test_id, angle, values["time_s"][rows],
                                 values["displacement_m"][rows],
                                 values["displacement_x_m"][rows], values["force_N"][rows],
                                 values["force_x_N"][rows], *own_specimen(table, test_id, rows)))
    return tuple(tests)
