"""Files in and out: every text input read by one guarded reader (:func:`read_text`), CSV
tables read by column name, JSON written strictly, and files written so that a reader never
sees half of one (a temporary file, then a rename).
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import stat
import tempfile
from collections.abc import Callable, Iterator, Mapping, Sequence
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
    NotFiniteResultError,
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
    return CsvTable(path, tuple(n for n, _ in numbered[1:]), cells)


class AtomicFile:
    """A file that appears at ``path`` whole or not at all: it is written at ``temporary`` (in
    the same folder), then renamed into place by :meth:`commit`; :meth:`discard` drops it.

    For writers that stream (a Rerun recording); :func:`write_atomic` for content in hand.
    As a context manager it discards the temporary file on leaving unless committed, whatever
    ends the block (an error, Ctrl-C, ``SystemExit``).

    Example:
        >>> import tempfile
        >>> with AtomicFile(Path(tempfile.mkdtemp()) / "log.txt") as target:
        ...     _ = target.temporary.write_text("done")
        ...     target.commit().read_text()
        'done'
    """

    _mode = 0o666  # what a plain open() gives a new file, less the umask

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        # The folders made for it, deepest first: a discarded file takes them back too.
        self._made = [p for p in (self.path.parent, *self.path.parent.parents)
                      if not p.exists()]
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.temporary = self._make_temporary()
        self.committed = False
        _PENDING.add(self)

    def _make_temporary(self) -> Path:
        fd, name = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".tmp",
                                    dir=self.path.parent)
        os.close(fd)
        return Path(name)

    def __enter__(self) -> AtomicFile:
        return self

    def __exit__(self, *exc_info: object) -> None:
        if not self.committed:
            self.discard()

    def commit(self) -> Path:
        """Rename the temporary file to ``path`` (replacing what was there) and return it."""
        # mkstemp makes the file private; give it the mode a plain open() would.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(self.temporary, self._mode & ~umask)
        os.replace(self.temporary, self.path)
        self.committed = True
        self.discard()  # no longer pending (nothing of the committed file is removed)
        return self.path

    def discard(self) -> None:
        """Remove the temporary file, and the folders made for it if they are empty again;
        ``path`` keeps what it had."""
        self.temporary.unlink(missing_ok=True)
        _PENDING.discard(self)
        for folder in self._made:
            try:
                folder.rmdir()
            except OSError:  # not empty: something else was written there since
                break


#: This process's :class:`AtomicFile` objects (folders too) not yet committed or discarded.
_PENDING: set[AtomicFile] = set()


def discard_pending() -> None:
    """Remove every temporary file an :class:`AtomicFile` of this process still holds: the
    command line's last word, for a stop signal that came between two lines of a writer's
    own cleanup.

    Example:
        >>> import tempfile
        >>> target = AtomicFile(Path(tempfile.mkdtemp()) / "log.txt")
        >>> discard_pending()
        >>> target.temporary.exists()
        False
    """
    for target in list(_PENDING):
        target.discard()


def write_atomic(path: str | Path, content: str | bytes) -> Path:
    """Write ``content`` to ``path`` through a temporary file in the same folder and a rename.

    Example:
        >>> import tempfile
        >>> write_atomic(Path(tempfile.mkdtemp()) / "summary.json", "{}").read_text()
        '{}'
    """
    with AtomicFile(path) as target:
        if isinstance(content, bytes):
            target.temporary.write_bytes(content)
        else:
            target.temporary.write_text(content)
        return target.commit()


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
    """Write ``payload`` as indented, strict JSON (no ``NaN`` or ``Infinity``, which strict
    readers refuse), atomically. A value that is not applicable is ``None`` (``null``).

    Raises:
        NotFiniteResultError: ``payload`` holds NaN or infinity (named by its key): the result
            diverged; nothing is written.

    Example:
        >>> import tempfile
        >>> write_json(Path(tempfile.mkdtemp()) / "r.json", {"rows": [{"gain": float("nan")}]})
        Traceback (most recent call last):
        cell.errors.NotFiniteResultError: ...r.json, rows[0].gain: nan is not a finite number;
        nothing written
    """
    return write_atomic(path, json_text(payload, path))


def json_text(payload: Any, path: str | Path) -> str:
    """``payload`` as the text :func:`write_json` writes to ``path``: to check a result
    before anything of a command is written.

    Raises:
        NotFiniteResultError: ``payload`` holds NaN or infinity (named by its key).
    """
    try:
        return json.dumps(payload, indent=2, sort_keys=False, allow_nan=False) + "\n"
    except ValueError:
        found = first_non_finite(payload)
        if found is None:  # another fault (a circular reference): the program's, not data
            raise
        raise NotFiniteResultError(path, found[0] or "(the whole value)", found[1]) from None


def first_non_finite(payload: Any) -> tuple[str, str] | None:
    """The dotted key and the text of the first NaN or infinity in a JSON-able ``payload``,
    or None when it has none.

    Example:
        >>> first_non_finite({"fit": {"rmse_n": [0.1, float("inf")]}})
        ('fit.rmse_n[1]', 'inf')
    """
    return next(_non_finite(payload, ""), None)


def _non_finite(value: Any, key: str) -> Iterator[tuple[str, str]]:
    if isinstance(value, float) and not math.isfinite(value):
        yield key, repr(value)
    elif isinstance(value, Mapping):
        for name, item in value.items():
            yield from _non_finite(item, f"{key}.{name}" if key else str(name))
    elif isinstance(value, list | tuple):
        for index, item in enumerate(value):
            yield from _non_finite(item, f"{key}[{index}]")


def figure_png(figure: Any, dpi: int = 110) -> bytes:
    """A matplotlib figure drawn as PNG bytes, for :func:`write_atomic`."""
    png = io.BytesIO()
    figure.savefig(png, format="png", dpi=dpi)
    return png.getvalue()
