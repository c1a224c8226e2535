"""The rows of a set's ``tests.csv``, grouped by test and split by kind (uniaxial or cut), so
that each kind's reader sees only its own rows and columns: in a set that mixes both, each row
leaves the other kind's columns empty, and a set of one kind needs none of the other's columns.

Example:
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "tests.csv"
    >>> _ = path.write_text("test_id,mode,time_s\\na,tension,0\\nb,cut,0\\na,tension,1\\n")
    >>> table, uniaxial, cuts = read_test_rows(path, "cut", ())
    >>> uniaxial, cuts
    ({'a': [0, 2]}, {'b': [1]})
    >>> rows_of(table, uniaxial)[1]
    {'a': [0, 1]}
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from cell.errors import CsvError, InputError
from cell.io import CsvTable, read_csv

#: The columns every row needs, of either kind.
KEY_COLUMNS = ("test_id", "mode", "time_s")


def read_test_rows(path: Path, cut_mode: str, optional: Sequence[str]
                   ) -> tuple[CsvTable, dict[str, list[int]], dict[str, list[int]]]:
    """``tests.csv`` read with :data:`KEY_COLUMNS` and those of the ``optional`` columns it
    has, and the row indices of each test: of the uniaxial tests, and of the cut tests (whose
    first row's mode is ``cut_mode``), each in the order of its first row.

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
    cuts = {test_id: rows for test_id, rows in groups.items()
            if table.cells["mode"][rows[0]] == cut_mode}
    return table, {t: rows for t, rows in groups.items() if t not in cuts}, cuts


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
