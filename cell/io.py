"""Files in: every text input read by one guarded reader (:func:`read_text`), CSV tables
read by column name, JSON read strictly. What a command writes: :mod:`cell.outputs`.
"""

from __future__ import annotations

import csv
import json
import stat
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from cell.errors import (
    CsvError,
    FileReadError,
    FileTooLargeError,
    InputError,
    MissingFileError,
    NotAFileError,
    NotTextError,
    UnreadableFileError,
    file_read_error,
)

InputKind = Literal["toml", "csv", "json", "mesh"]
_MIB = 1 << 20
#: The largest input file of each kind, bytes: far above any real one (TOML files are kB; an
#: hour of a test at 1 kHz is 200 MiB of CSV; a scan of 10 million triangles 500 MiB of STL),
#: low enough to refuse a wrong file (a video, a disk image) before it fills memory.
MAX_INPUT_BYTES: dict[str, int] = {"toml": 16 * _MIB, "csv": 256 * _MIB, "json": 64 * _MIB,
                                   "mesh": 1024 * _MIB}


def read_bytes(path: str | Path, kind: InputKind, error: type[InputError] = InputError
               ) -> bytes:
    """The content of the file ``path``, an input of ``kind`` (for a size limit,
    :data:`MAX_INPUT_BYTES`).

    Raises:
        FileReadError: (also an ``error``: :func:`cell.errors.file_read_error`) naming the
            file: missing, not a file (a folder, a pipe), unreadable, too large.

    Example:
        >>> read_bytes("assets", "toml")
        Traceback (most recent call last):
        cell.errors.NotAFileError: assets: a folder, not a file
    """
    path = Path(path)
    limit = MAX_INPUT_BYTES[kind]

    def fault(kind_of_fault: type[FileReadError], message: str) -> FileReadError:
        return file_read_error(kind_of_fault, error)(path, None, message)

    try:
        # stat first: opening a named pipe would wait for a writer, maybe forever.
        mode = path.stat().st_mode
        if stat.S_ISDIR(mode):
            raise fault(NotAFileError, "a folder, not a file")
        if not stat.S_ISREG(mode):
            raise fault(NotAFileError, "not a regular file (a pipe, socket or device)")
        with path.open("rb") as handle:
            content = handle.read(limit + 1)
    except FileNotFoundError:
        raise fault(MissingFileError, "file not found") from None
    except NotADirectoryError:
        raise fault(MissingFileError, "file not found: a part of its path is a file, "
                    "not a folder") from None
    except PermissionError:
        raise fault(UnreadableFileError, "cannot read: permission denied") from None
    except (OSError, ValueError) as exc:  # ValueError: a NUL in the path
        raise fault(UnreadableFileError, f"cannot read: {exc}") from None
    if len(content) > limit:
        raise fault(FileTooLargeError, f"larger than any {kind} input musclecell reads "
                    f"(limit {limit // _MIB} MiB): the wrong file?")
    return content


def read_text(path: str | Path, kind: InputKind, error: type[InputError] = InputError) -> str:
    """The text of the file ``path``, an input of ``kind``: UTF-8, with or without the
    byte-order mark that spreadsheets and some editors write. Every text input of musclecell
    is read through here.

    Raises:
        FileReadError: as :func:`read_bytes`, and :class:`~cell.errors.NotTextError` for a
            file that is not UTF-8 text (or holds NUL bytes: a binary file).

    Example:
        >>> read_text("scenarios/default.toml", "toml").startswith("#")
        True
    """
    content = read_bytes(path, kind, error)
    try:
        text = content.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise file_read_error(NotTextError, error)(
            path, None, f"not UTF-8 text (byte 0x{exc.object[exc.start]:02x}): a binary "
            "file?") from None
    if "\x00" in text:
        raise file_read_error(NotTextError, error)(
            path, None, "not text (it holds NUL bytes): a binary file?")
    return text


def read_json(path: str | Path, error: type[InputError] = InputError) -> Any:
    """The JSON value in the file ``path`` (read by :func:`read_text`), strictly: ``NaN`` and
    ``Infinity``, which are not JSON, are refused.

    Raises:
        FileReadError: as :func:`read_text`.
        InputError: (``error``) not valid JSON, naming the line.
    """

    def refuse(constant: str) -> Any:
        raise ValueError(f"{constant} is not a JSON number")

    try:
        return json.loads(read_text(path, "json", error), parse_constant=refuse)
    except json.JSONDecodeError as exc:
        raise error(path, f"line {exc.lineno}", f"not valid JSON: {exc.msg}") from None
    except ValueError as exc:
        raise error(path, None, f"not valid JSON: {exc}") from None


@dataclass(frozen=True)
class CsvTable:
    """The rows of a CSV file, by column: the text of each cell and the file line of its row.

    Attributes:
        path: the file read.
        lines: the file's line number (from 1) of each row.
        cells: per column asked for (and optional column the file has), the cell text of
            each row, blanks stripped.
        header: every column the file has, in its order.

    Example:
        >>> table = read_csv("assets/cutting_force/boning_knife_synthetic.csv", ["time_s"])
        >>> table.lines[0], float(table.numbers("time_s")[0])
        (7, 0.0)
    """

    path: Path
    lines: tuple[int, ...]
    cells: dict[str, list[str]]
    header: tuple[str, ...] = ()

    def where(self, row: int, column: str) -> str:
        """The field of a cell, as errors name it: ``line N, column C``."""
        return f"line {self.lines[row]}, column {column}"

    def numbers(self, column: str, refusal: Callable[[float], str | None] | None = None
                ) -> np.ndarray:
        """Column ``column`` as finite floats, none of which ``refusal`` refuses (it says why
        a value is refused, or None: :meth:`cell.config.Plausible.refusal`).

        Raises:
            CsvError: naming the line and column of the first cell that is not a finite
                number, or that ``refusal`` refuses.
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
        for row, value in enumerate(values if refusal is not None else ()):
            why = refusal(float(value))
            if why is not None:
                raise CsvError(self.path, self.where(row, column), why)
        return values


def read_csv(path: str | Path, columns: Sequence[str], optional: Sequence[str] = ()
             ) -> CsvTable:
    """Read the ``columns`` of a CSV file with a header line, by name, and those of the
    ``optional`` columns it has.

    Accepts what spreadsheets write: a UTF-8 byte-order mark, CRLF line ends, columns in any
    order, extra columns (ignored). Blank lines and lines starting with ``#`` are skipped.

    Raises:
        CsvError: naming the file, and ``line N, column C`` where it applies: a file that
            :func:`read_text` refuses, no header line, a missing column, a row too short.
    """
    path = Path(path)
    text = read_text(path, "csv", CsvError)
    numbered = [(n, line) for n, line in enumerate(text.splitlines(), start=1)
                if line.strip() and not line.lstrip().startswith("#")]
    if not numbered:
        raise CsvError(path, None, "no header line")
    header_line, header = numbered[0]
    names = [c.strip() for c in next(csv.reader([header]))]
    for name in columns:
        if name not in names:
            raise CsvError(path, f"line {header_line}, column {name}", "missing column")
    index = {name: names.index(name) for name in (*columns, *optional) if name in names}
    cells: dict[str, list[str]] = {name: [] for name in index}
    # Each line parsed alone: a stray quote must not swallow the lines after it.
    for number, row in ((n, next(csv.reader([line]))) for n, line in numbered[1:]):
        short = [name for name in index if index[name] >= len(row)]
        if short:
            raise CsvError(path, f"line {number}, column {short[0]}",
                           f"missing value: the row has {len(row)} fields")
        for name, col in index.items():
            cells[name].append(row[col].strip())
    return CsvTable(path, tuple(n for n, _ in numbered[1:]), cells, tuple(names))
