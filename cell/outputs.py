"""What a command writes, outputs first: every path checked before the command does any work
(:func:`check_outputs`), so that a path that cannot be written stops it at once with nothing
written; then each file written to a temporary sibling and renamed into place
(:func:`write_atomic`; :func:`write_json` strictly, :func:`write_rows`, :class:`AtomicFile`
for a writer that streams), so that a stopped command leaves no half of one. Files that
belong together (a policy's weights and statistics, a report and its table) are written by
:func:`write_together`, none renamed before every one is written; an output folder filled
whole goes the same way (:mod:`cell.folders`). What a command reads: :mod:`cell.io`.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import tempfile
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cell.errors import NotFiniteResultError, OutputError


@dataclass(frozen=True)
class Output:
    """One path a command writes.

    Attributes:
        path: the file (or folder) to write.
        option: the command-line option or argument that named it (``--json``), for errors.
        folder: a folder the command fills with files, not one file.
        whole: a folder written whole (:func:`cell.folders.write_folder`): it replaces one
            that is there, so it may not hold the working folder, the home folder, an input
            or another output.
        marks: for a folder written whole, the files one of which an earlier output of the
            command holds (in it or in a folder in it): a folder there that is not empty and
            holds none of them is someone else's and is refused, not replaced.

    Example:
        >>> Output(Path("out/plan.json"), "--json").folder
        False
    """

    path: Path
    option: str
    folder: bool = False
    whole: bool = False
    marks: tuple[str, ...] = ()


def check_outputs(outputs: Iterable[Output | None], inputs: Iterable[str | Path | None] = ()
                  ) -> None:
    """Check that each output can be written, before any work; ``None`` entries (an option
    not given) are skipped.

    An output passes when the nearest folder that exists on its way is writable (the missing
    ones can be made), it is not a folder where a file goes (nor a file where a folder goes),
    it is not one of the ``inputs``, and no two outputs are the same file; a folder written
    whole holds none of the inputs, the other outputs, the working and the home folder, and
    replaces only an empty folder or the command's own earlier output (:attr:`Output.marks`).

    Raises:
        OutputError: naming the path and the option, for the first output that fails.

    Example:
        >>> import tempfile
        >>> folder = Path(tempfile.mkdtemp())
        >>> check_outputs([Output(folder / "new" / "run.json", "--summary")])
        >>> check_outputs([Output(folder, "--json")])  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        cell.errors.OutputError: ..., --json: is a folder; give a file name
    """
    given = [output for output in outputs if output is not None]
    sources = [Path(p) for p in inputs if p is not None]
    seen: dict[Path, str] = {}
    for output in given:
        _check_one(output, sources)
        resolved = output.path.resolve()
        if resolved in seen:
            raise OutputError(output.path, output.option,
                              f"is also the output of {seen[resolved]}; give another path")
        seen[resolved] = output.option
    for output in (output for output in given if output.whole):
        held = [(Path.cwd(), "the working folder"), (Path("~").expanduser(), "the home folder"),
                *((source, f"the input {source}") for source in sources),
                *((other.path, f"the output of {other.option}") for other in given
                  if other is not output)]
        for path, what in held:
            if _holds(output.path, path):
                raise OutputError(output.path, output.option, f"holds {what}, and the "
                                  "folder written replaces it whole; give a folder of its own")
        if output.path.is_dir() and _someone_elses(output.path, output.marks):
            raise OutputError(output.path, output.option, "holds files that are no earlier "
                              f"output of this command (it would hold {' or '.join(output.marks)}"
                              "), and the folder written replaces it whole; give a new or empty "
                              "folder")


def write_together(contents: Mapping[Path, str | bytes]) -> list[Path]:
    """Write each of ``contents`` (path to text or bytes) as one change: every file to its
    temporary sibling first, then the renames, so that an error or a stop while they are
    written leaves every path as it was.

    Example:
        >>> import tempfile
        >>> folder = Path(tempfile.mkdtemp())
        >>> [path.name for path in write_together({folder / "a.json": "{}", folder / "a.md": ""})]
        ['a.json', 'a.md']
    """
    targets = []
    try:
        for path, content in contents.items():
            targets.append(AtomicFile(path))
            if isinstance(content, bytes):
                targets[-1].temporary.write_bytes(content)
            else:
                targets[-1].temporary.write_text(content)
        return [target.commit() for target in targets]
    finally:
        for target in targets:
            if not target.committed:
                target.discard()


def _check_one(output: Output, inputs: list[Path]) -> None:
    path, option = output.path, output.option
    for source in inputs:
        if _same(path, source):
            raise OutputError(path, option, f"is the input {source}; give another path")
    if path.is_dir() and not output.folder:
        raise OutputError(path, option, "is a folder; give a file name")
    if path.exists() and output.folder and not path.is_dir():
        raise OutputError(path, option, "is a file; give a folder")
    if path.exists() and not output.folder and not path.is_file():
        raise OutputError(path, option, "is not a regular file")
    if (path.is_file() or (output.whole and path.is_dir())) and not os.access(path, os.W_OK):
        raise OutputError(path, option, "is read-only")
    # The file (or whole folder) is written as a temporary sibling and renamed: the folder
    # that will hold it (or the nearest one that exists, where the missing ones will be made)
    # must take files.
    holder = path if output.folder and not output.whole and path.is_dir() else path.parent
    while not holder.exists() and not holder.is_symlink() and holder != holder.parent:
        holder = holder.parent
    if not holder.is_dir():
        raise OutputError(path, option, f"{holder} is not a folder")
    if not os.access(holder, os.W_OK | os.X_OK):
        raise OutputError(path, option, f"cannot write in {holder}")


def _someone_elses(folder: Path, marks: tuple[str, ...]) -> bool:
    """``folder`` holds something and none of ``marks``, in it or in a folder in it."""
    entries = list(folder.iterdir())
    places = [folder, *(entry for entry in entries if entry.is_dir())]
    return bool(entries) and not any((place / mark).is_file() for place in places
                                     for mark in marks)


def _holds(folder: Path, path: Path) -> bool:
    """``folder`` is ``path`` or one of the folders above it (through links)."""
    folder, path = folder.resolve(), path.resolve()
    return folder == path or folder in path.parents


def _same(output: Path, source: Path) -> bool:
    """``output`` is ``source`` (through links and relative paths alike)."""
    if output.exists() and source.exists():
        return os.path.samefile(output, source)
    return output.resolve() == source.resolve()


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
    """Write ``content`` to ``path`` through a temporary file in the same folder and a rename
    (one file of :func:`write_together`).

    Example:
        >>> import tempfile
        >>> write_atomic(Path(tempfile.mkdtemp()) / "summary.json", "{}").read_text()
        '{}'
    """
    return write_together({Path(path): content})[0]


def write_rows(path: str | Path, columns: Sequence[str], rows: Sequence[Mapping[str, Any]]
               ) -> Path:
    """Write :func:`rows_text` of ``rows`` atomically."""
    return write_atomic(path, rows_text(columns, rows))


def rows_text(columns: Sequence[str], rows: Sequence[Mapping[str, Any]]) -> str:
    """``rows`` as CSV with a header of ``columns`` (a missing cell is blank).

    Example:
        >>> rows_text(["a", "b"], [{"a": 1}]).splitlines()
        ['a,b', '1,']
    """
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=list(columns), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return text.getvalue()


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
