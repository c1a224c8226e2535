"""Files in and out: CSV tables read by column name; files written so that a reader never
sees half of one (a temporary file, then a rename)."""

from __future__ import annotations

import csv
import io
import json
import os
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cell.errors import CsvError


@dataclass(frozen=True)
class CsvTable:
    """The rows of a CSV file, by column: the text of each cell and the file line of its row.

    Attributes:
        path: the file read.
        lines: the file's line number (from 1) of each row.
        cells: per column asked for, the cell text of each row, blanks stripped.

    Example:
        >>> table = read_csv("assets/cutting_force/boning_knife_synthetic.csv", ["time_s"])
        >>> table.lines[0], float(table.numbers("time_s")[0])
        (7, 0.0)
    """

    path: Path
    lines: tuple[int, ...]
    cells: dict[str, list[str]]

    def where(self, row: int, column: str) -> str:
        """The field of a cell, as errors name it: ``line N, column C``."""
        return f"line {self.lines[row]}, column {column}"

    def numbers(self, column: str) -> np.ndarray:
        """Column ``column`` as finite floats.

        Raises:
            CsvError: naming the line and column of the first cell that is not a finite number.
        """
        values = np.empty(len(self.lines))
        for row, cell in enumerate(self.cells[column]):
            try:
                values[row] = float(cell)
            except ValueError:
                raise CsvError(self.path, self.where(row, column),
                               f"not a number: {cell!r}") from None
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise CsvError(self.path, self.where(int(bad[0]), column),
                           f"not finite: {self.cells[column][bad[0]]!r}")
        return values


def read_csv(path: str | Path, columns: Sequence[str]) -> CsvTable:
    """Read the ``columns`` of a CSV file with a header line, by name.

    Accepts what spreadsheets write: a UTF-8 byte-order mark, CRLF line ends, columns in any
    order, extra columns (ignored). Blank lines and lines starting with ``#`` are skipped.

    Raises:
        CsvError: naming the file, and ``line N, column C`` where it applies: a file that is
            missing or unreadable, no header line, a missing column, a row too short.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise CsvError(path, None, "file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CsvError(path, None, f"cannot read: {exc}") from None
    numbered = [(n, line) for n, line in enumerate(text.splitlines(), start=1)
                if line.strip() and not line.lstrip().startswith("#")]
    if not numbered:
        raise CsvError(path, None, "no header line")
    header_line, header = numbered[0]
    names = [c.strip() for c in next(csv.reader([header]))]
    for name in columns:
        if name not in names:
            raise CsvError(path, f"line {header_line}, column {name}", "missing column")
    index = {name: names.index(name) for name in columns}
    cells: dict[str, list[str]] = {name: [] for name in columns}
    rows = csv.reader(line for _, line in numbered[1:])
    for (number, _), row in zip(numbered[1:], rows, strict=True):
        short = [name for name in columns if index[name] >= len(row)]
        if short:
            raise CsvError(path, f"line {number}, column {short[0]}",
                           f"missing value: the row has {len(row)} fields")
        for name, col in index.items():
            cells[name].append(row[col].strip())
    return CsvTable(path, tuple(n for n, _ in numbered[1:]), cells)


class AtomicFile:
    """A file that appears at ``path`` whole or not at all: it is written at ``temporary`` (in
    the same folder), then renamed into place by :meth:`commit`; :meth:`discard` drops it.

    For writers that stream (a Rerun recording); :func:`write_atomic` for content in hand.

    Example:
        >>> import tempfile
        >>> target = AtomicFile(Path(tempfile.mkdtemp()) / "log.txt")
        >>> _ = target.temporary.write_text("done")
        >>> target.commit().read_text()
        'done'
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".tmp",
                                    dir=self.path.parent)
        os.close(fd)
        self.temporary = Path(name)

    def commit(self) -> Path:
        """Rename the temporary file to ``path`` (replacing what was there) and return it."""
        # mkstemp makes the file private; give it the mode a plain open() would.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(self.temporary, 0o666 & ~umask)
        os.replace(self.temporary, self.path)
        return self.path

    def discard(self) -> None:
        """Remove the temporary file; ``path`` keeps what it had."""
        self.temporary.unlink(missing_ok=True)


def write_atomic(path: str | Path, content: str | bytes) -> Path:
    """Write ``content`` to ``path`` through a temporary file in the same folder and a rename.

    Example:
        >>> import tempfile
        >>> write_atomic(Path(tempfile.mkdtemp()) / "summary.json", "{}").read_text()
        '{}'
    """
    target = AtomicFile(path)
    try:
        if isinstance(content, bytes):
            target.temporary.write_bytes(content)
        else:
            target.temporary.write_text(content)
        return target.commit()
    except BaseException:
        target.discard()
        raise


def write_rows(path: str | Path, columns: Sequence[str], rows: Sequence[Mapping[str, Any]]
               ) -> Path:
    """Write ``rows`` as CSV with a header of ``columns`` (a missing cell is blank),
    atomically.

    Example:
        >>> import tempfile
        >>> path = write_rows(Path(tempfile.mkdtemp()) / "t.csv", ["a", "b"], [{"a": 1}])
        >>> path.read_text().splitlines()
        ['a,b', '1,']
    """
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=list(columns), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return write_atomic(path, text.getvalue())


def write_json(path: str | Path, payload: Any) -> Path:
    """Write ``payload`` as indented JSON, atomically."""
    return write_atomic(path, json.dumps(payload, indent=2, sort_keys=False) + "\n")


def figure_png(figure: Any, dpi: int = 110) -> bytes:
    """A matplotlib figure drawn as PNG bytes, for :func:`write_atomic`."""
    png = io.BytesIO()
    figure.savefig(png, format="png", dpi=dpi)
    return png.getvalue()
