"""A results folder of a sweep or a batch: one JSON record per finished run, kept as runs
finish so that a sweep that stops (or is stopped) resumes where it was, and the table of all
rows as Parquet (for programs) and CSV (for people and spreadsheets).

Layout::

    DIR/runs/<name>.json       one record per finished run: fingerprint, row, traceback
    DIR/<table>.parquet        every row, one column per swept value and result
    DIR/<table>.csv            the same rows
"""

from __future__ import annotations

import hashlib
import io
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from cell.errors import SweepError
from cell.io import read_json
from cell.outputs import write_atomic, write_json, write_rows

RUNS_FOLDER = "runs"


def fingerprint(task: object) -> str:
    """A run's identity: a hash of everything its worker gets (scenario, seed, values), so
    that a changed sweep re-plays the runs it changed and only those.

    Example:
        >>> fingerprint(("a", 1)) == fingerprint(("a", 1)) != fingerprint(("a", 2))
        True
    """
    return hashlib.sha256(repr(task).encode()).hexdigest()[:16]


class ResultsFolder:
    """The results folder ``folder`` (module docstring); made with the first record saved.

    Example:
        >>> import tempfile
        >>> results = ResultsFolder(Path(tempfile.mkdtemp()))
        >>> _ = results.save("run-0000", {"fingerprint": "f0", "row": {"run": 0}})
        >>> list(results.finished())
        ['run-0000']
    """

    def __init__(self, folder: str | Path) -> None:
        self.folder = Path(folder)
        if self.folder.exists() and not self.folder.is_dir():
            raise SweepError(self.folder, None, "not a folder")
        # Nothing made yet: the folders appear with the first record, so that a sweep that
        # stops before any run (no Ray, an unreachable cluster) leaves no empty folder.

    def finished(self) -> dict[str, dict[str, Any]]:
        """The records of the finished runs, by run name.

        Raises:
            SweepError: a record that is not a run's JSON (edited by hand?), naming it.
        """
        records = {}
        for path in sorted((self.folder / RUNS_FOLDER).glob("*.json")):
            record = read_json(path, SweepError)
            if not isinstance(record, dict) or not isinstance(record.get("row"), dict):
                raise SweepError(path, "row", "missing: not a run record")
            records[path.stem] = record
        return records

    def save(self, name: str, record: dict[str, Any]) -> Path:
        """Keep a finished run's record (atomically: a stopped sweep leaves none half
        written)."""
        return write_json(self.folder / RUNS_FOLDER / f"{name}.json", record)

    def write_table(self, stem: str, rows: Sequence[dict[str, Any]]) -> tuple[Path, Path]:
        """``rows`` as ``<stem>.parquet`` and ``<stem>.csv``; the columns are every key of
        the rows in the order they first appear, a missing cell empty."""
        columns = list(dict.fromkeys(key for row in rows for key in row))
        parquet = io.BytesIO()
        pq.write_table(_arrow_table(columns, rows), parquet)
        return (write_atomic(self.folder / f"{stem}.parquet", parquet.getvalue()),
                write_rows(self.folder / f"{stem}.csv", columns, rows))


def _arrow_table(columns: list[str], rows: Sequence[dict[str, Any]]) -> pa.Table:
    """The rows by column; a column whose cells share no type (a swept value that is a
    number in one run and a word in another) is kept as text."""
    arrays = {}
    for column in columns:
        cells = [row.get(column) for row in rows]
        try:
            arrays[column] = pa.array(cells)
        except (pa.ArrowInvalid, pa.ArrowTypeError):
            arrays[column] = pa.array([None if c is None else str(c) for c in cells])
    return pa.table(arrays)
