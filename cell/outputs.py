"""Outputs first: every path a command will write, checked before the command does any work,
so that a path that cannot be written stops it at once, with nothing written.

A command lists its outputs (each with the option that named it) and its inputs, and calls
:func:`check_outputs`. The files themselves are written later through :mod:`cell.io`, to a
temporary sibling renamed into place, so that a stopped command leaves no half of one; an
output folder filled whole goes the same way (:mod:`cell.folders`).
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from cell.errors import OutputError


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
