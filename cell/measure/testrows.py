"""The rows of a set's ``tests.csv``, grouped by test and split by kind (uniaxial, shear,
biaxial or cut), so that each kind's reader sees only its own rows and columns: in a set that
mixes kinds, each row leaves the other kinds' columns empty, and a set of one kind needs none of
the others' columns; and the checks and columns every kind shares (:func:`check_rows`, the
per-test specimen columns :func:`own_specimen` reads).

Example:
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "tests.csv"
    >>> _ = path.write_text("test_id,mode,time_s\\na,tension,0\\nb,cut,0\\na,tension,1\\n")
    >>> table, kinds = read_test_rows(path, ("cut", "shear"), ())
    >>> kinds
    {'': {'a': [0, 2]}, 'cut': {'b': [1]}, 'shear': {}}
    >>> rows_of(table, kinds[""])[1]
    {'a': [0, 1]}
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cell.config import LENGTH_M
from cell.errors import CsvError, InputError
from cell.io import CsvTable, read_csv

#: The columns every row needs, of every kind.
KEY_COLUMNS = ("test_id", "mode", "time_s")
#: Optional columns of every kind but cuts: the test's specimen and its own edge lengths.
SPECIMEN_COLUMNS = ("specimen", "size_x_m", "size_y_m", "size_z_m")
#: The fewest samples a test may have.
MIN_SAMPLES = 3


def read_test_rows(path: Path, own_modes: Sequence[str], optional: Sequence[str]
                   ) -> tuple[CsvTable, dict[str, dict[str, list[int]]]]:
    """``tests.csv`` read with :data:`KEY_COLUMNS` and those of the ``optional`` columns it
    has, and the row indices of each test by kind, each in the order of its first row: under
    each of ``own_modes`` (modes that have a reader of their own) the tests whose first row
    has that mode, under ``""`` all others (the uniaxial reader's, which names unknown modes).

    Raises:
        CsvError: as :func:`cell.io.read_csv`.
        InputError: an empty test id, no test at all.
    """
    table = read_csv(path, KEY_COLUMNS, optional)
    groups: dict[str, list[int]] = {}
    for row, test_id in enumerate(table.cells["test_id"]):
        if not test_id:
            raise InputError(path, table.where(row, "test_id"), "empty test id")
        groups.setdefault(test_id, []).append(row)
    if not groups:
        raise InputError(path, None, "no tests: the set needs at least one")
    kinds: dict[str, dict[str, list[int]]] = {mode: {} for mode in ("", *own_modes)}
    for test_id, rows in groups.items():
        mode = table.cells["mode"][rows[0]]
        kinds[mode if mode in own_modes else ""][test_id] = rows
    return table, kinds


def require_columns(table: CsvTable, columns: Sequence[str]) -> None:
    """Raise if ``table`` lacks one of ``columns`` (read as optional, needed by the rows of a
    kind the file holds).

    Raises:
        CsvError: naming the header's line and the missing column, as :func:`cell.io.read_csv`
            names a missing column (it reads the header again to name its line).
    """
    missing = [name for name in columns if name not in table.cells]
    if missing:
        read_csv(table.path, columns)
        raise CsvError(table.path, f"column {missing[0]}", "missing column")  # file changed


def rows_of(table: CsvTable, groups: Mapping[str, Sequence[int]]
            ) -> tuple[CsvTable, dict[str, list[int]]]:
    """The table of only the rows of ``groups`` (a test's row indices into ``table``), their
    file lines kept, and each test's row indices into it."""
    rows = sorted(row for members in groups.values() for row in members)
    position = {row: index for index, row in enumerate(rows)}
    subset = CsvTable(table.path, tuple(table.lines[row] for row in rows),
                      {name: [cells[row] for row in rows] for name, cells in table.cells.items()})
    return subset, {name: [position[row] for row in members] for name, members in groups.items()}


class OwnSize:
    """A test that may carry its own specimen (``specimen_id``, ``size_m`` as
    :func:`own_specimen` reads them): every kind of test but cuts."""

    size_m: tuple[float, float, float] | None

    def size_of(self, specimen: Any) -> tuple[float, float, float]:
        """The test's edge lengths along x, y, z, m: its own, else ``specimen``'s."""
        return tuple(specimen.size_m) if self.size_m is None else self.size_m


def check_rows(table: CsvTable, test_id: str, rows: Sequence[int], time_s: np.ndarray) -> None:
    """Check the rows of one test (``rows``: indices into ``table``; ``time_s`` their times):
    one mode throughout, at least :data:`MIN_SAMPLES` samples, time never going backwards.

    Raises:
        InputError: naming the file, line and column at fault.
    """
    modes = [table.cells["mode"][row] for row in rows]
    changed = next((i for i, mode in enumerate(modes) if mode != modes[0]), None)
    if changed is not None:
        raise InputError(table.path, table.where(rows[changed], "mode"), f"test {test_id!r} "
                         f"changes mode from {modes[0]!r} to {modes[changed]!r}")
    if len(rows) < MIN_SAMPLES:
        raise InputError(table.path, table.where(rows[0], "test_id"), f"test {test_id!r} has "
                         f"{len(rows)} samples, needs at least {MIN_SAMPLES}")
    back = np.flatnonzero(np.diff(time_s) < 0)
    if back.size:
        row = back[0] + 1
        raise InputError(table.path, table.where(rows[row], "time_s"),
                         f"time goes backwards in test {test_id!r}: {time_s[row]:g} s after "
                         f"{time_s[row - 1]:g} s")


def constant(table: CsvTable, column: str, values: np.ndarray, test_id: str,
             rows: Sequence[int], unit: str) -> float:
    """The value of ``column`` (``values``: the column's numbers at ``rows``) that one test
    keeps throughout.

    Raises:
        InputError: the value changes within the test (naming the first row that changes it).
    """
    changed = np.flatnonzero(values != values[0])
    if changed.size:
        raise InputError(table.path, table.where(rows[changed[0]], column),
                         f"test {test_id!r} changes {column} from {values[0]:g} {unit} to "
                         f"{values[changed[0]]:g} {unit}")
    return float(values[0])


def own_specimen(table: CsvTable, test_id: str, rows: Sequence[int]
                 ) -> tuple[str, tuple[float, float, float] | None]:
    """A test's own specimen, from the optional :data:`SPECIMEN_COLUMNS`: its name (``""``
    when the column is absent or empty) and its edge lengths along x, y, z, m (None when the
    size columns are absent or empty: the set's ``size_m`` then holds).

    Raises:
        InputError: a name or size that changes within the test, some of the three sizes
            given but not all, a size that is not a number or not a plausible length.
    """
    names = [table.cells.get("specimen", [""] * len(table.lines))[row] for row in rows]
    changed = next((i for i, name in enumerate(names) if name != names[0]), None)
    if changed is not None:
        raise InputError(table.path, table.where(rows[changed], "specimen"), f"test "
                         f"{test_id!r} names more than one specimen: {names[0]!r}, "
                         f"{names[changed]!r}")
    cells = [[table.cells.get(column, [""] * len(table.lines))[row] for row in rows]
             for column in SPECIMEN_COLUMNS[1:]]
    given = [any(column) for column in cells]
    if not any(given):
        return names[0], None
    sizes = []
    for column, values in zip(SPECIMEN_COLUMNS[1:], cells, strict=True):
        missing = next((i for i, cell in enumerate(values) if not cell), None)
        if missing is not None:
            raise InputError(table.path, table.where(rows[missing], column),
                             f"empty, where test {test_id!r} gives its own size: it gives "
                             f"all of {', '.join(SPECIMEN_COLUMNS[1:])} on every row, or none")
        numbers = CsvTable(table.path, tuple(table.lines[row] for row in rows),
                           {column: values}).numbers(column, LENGTH_M.refusal)
        sizes.append(constant(table, column, numbers, test_id, rows, "m"))
    return names[0], (sizes[0], sizes[1], sizes[2])
