"""Output folders that appear whole or not at all: a command fills its folder (a report, a
log, a replay) in a temporary folder beside it, renamed into place once every file is in, as
:class:`cell.outputs.AtomicFile` does for one file. A stopped or failed command leaves neither
the folder nor the temporary one, and a folder that was there keeps what it had. Several
outputs of one command (a report, a material, a JSON) can appear together the same way
(:func:`write_together`).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path

from cell.outputs import AtomicFile


class AtomicFolder(AtomicFile):
    """A folder that appears at ``path`` whole or not at all: its files are written into
    ``temporary`` (an empty folder beside it), which :meth:`commit` renames into place,
    replacing a folder there whole, as :class:`~cell.outputs.AtomicFile` replaces a file;
    :meth:`discard` drops it. A link at ``path`` is followed: it keeps pointing at the new
    folder.

    As a context manager it discards the temporary folder on leaving unless committed,
    whatever ends the block (an error, Ctrl-C, ``SystemExit``); the command line's
    :func:`cell.outputs.discard_pending` removes what a stop in the middle of that left.

    Example:
        >>> import tempfile
        >>> with AtomicFolder(Path(tempfile.mkdtemp()) / "report") as target:
        ...     _ = (target.temporary / "report.md").write_text("done")
        ...     [p.name for p in target.commit().iterdir()]
        ['report.md']
    """

    _mode = 0o777  # what a plain mkdir() gives a new folder, less the umask

    def __init__(self, path: str | Path) -> None:
        self._old: Path | None = None  # the folder that was at path, while commit replaces it
        # Absolute, ".." taken out: the temporary folder goes beside the folder named.
        path = Path(os.path.abspath(path))
        super().__init__(path.resolve() if path.is_symlink() else path)

    def _make_temporary(self) -> Path:
        return Path(tempfile.mkdtemp(prefix=f".{self.path.name}.", suffix=".tmp",
                                     dir=self.path.parent))

    def commit(self) -> Path:
        """Rename the temporary folder to ``path`` (replacing a folder there) and return it."""
        if self.path.is_dir():
            # A folder is renamed only onto an empty one: the old folder moves aside first
            # (onto an empty one made for it), and goes once the new one is in.
            self._old = Path(tempfile.mkdtemp(prefix=f".{self.path.name}.", suffix=".old",
                                              dir=self.path.parent))
            os.replace(self.path, self._old)
        return super().commit()

    def discard(self) -> None:
        """Remove the temporary folder and the folders made for it; an old folder moved aside
        goes too once the new one is in, and back to ``path`` if a stop or an error came
        between the two renames of :meth:`commit`."""
        if self._old is not None and not self.path.exists():
            os.replace(self._old, self.path)
        for folder in (self.temporary, self._old):
            if folder is not None:
                shutil.rmtree(folder, ignore_errors=True)
        super().discard()


def write_folder(path: str | Path, fill: Callable[[Path], object]) -> Path:
    """Fill the folder ``path`` whole or not at all (:class:`AtomicFolder`): ``fill`` writes
    its files into the temporary folder it is given; returns ``path`` (absolute).

    Example:
        >>> import tempfile
        >>> out = Path(tempfile.mkdtemp()) / "out"
        >>> write_folder(out, lambda folder: (folder / "a.txt").write_text("a")).name
        'out'
    """
    with AtomicFolder(path) as target:
        fill(target.temporary)
        return target.commit()


def write_files_and_folders(files: Mapping[Path, str | bytes],
                            folders: Mapping[Path, Callable[[Path], object]] | None = None
                            ) -> None:
    """Write ``files`` (path to content) and ``folders`` (path to the function that fills the
    temporary folder it is given) as one output: every one is filled in its temporary first,
    and they are renamed into place one after the other only once all are filled, so a
    failure or a stop while filling leaves none of them.

    Example:
        >>> import tempfile
        >>> out = Path(tempfile.mkdtemp())
        >>> write_files_and_folders({out / "a.json": "{}"}, {out / "report": lambda f: None})
        >>> sorted(p.name for p in out.iterdir())
        ['a.json', 'report']
    """
    with contextlib.ExitStack() as stack:
        targets: list[AtomicFile] = []
        for path, fill in (folders or {}).items():
            folder = stack.enter_context(AtomicFolder(path))
            fill(folder.temporary)
            targets.append(folder)
        for path, content in files.items():
            target = stack.enter_context(AtomicFile(path))
            if isinstance(content, bytes):
                target.temporary.write_bytes(content)
            else:
                target.temporary.write_text(content)
            targets.append(target)
        for target in targets:
            target.commit()
