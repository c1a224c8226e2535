"""The command line's promise for bad input, as one check: exit 2 naming file and key, no
traceback, and the working folder (the output folder in it) left as it was."""

from __future__ import annotations

import contextlib
import hashlib
import io
import traceback
from pathlib import Path

from cell.cli import main


def snapshot(folder: Path) -> dict[str, str]:
    """Every entry under ``folder`` by relative path: a folder, or its file's hash."""
    entries = {}
    for path in sorted(folder.rglob("*")):
        key = path.relative_to(folder).as_posix()
        entries[key] = "folder" if path.is_dir() else hashlib.sha256(path.read_bytes()
                                                                     ).hexdigest()
    return entries


def run_command(cwd: Path, *args: str) -> tuple[int, str]:
    """``musclecell ARGS`` run in ``cwd`` by this process, as the console script runs it:
    its exit code and what it wrote to stderr, an uncaught exception as its traceback with
    exit code 1, as Python prints it. In this process rather than a new one, whose imports
    would take longer than most refusals."""
    stderr = io.StringIO()
    with (contextlib.chdir(cwd), contextlib.redirect_stderr(stderr),
          contextlib.redirect_stdout(io.StringIO())):
        try:
            code = main(list(args))
        except SystemExit as exit_:  # argparse's refusals
            code = exit_.code if isinstance(exit_.code, int) else 1 if exit_.code else 0
        except Exception:
            traceback.print_exc()
            code = 1
    return code, stderr.getvalue()


def refused(cwd: Path, *args: str, words: tuple[str, ...], code: int = 2) -> str:
    """Run ``musclecell ARGS`` in ``cwd``; check that it exits ``code`` naming each of
    ``words`` without a traceback, and leaves ``cwd`` as it was; return the
    message."""
    before = snapshot(cwd)
    returncode, stderr = run_command(cwd, *args)
    assert returncode == code, stderr
    assert "Traceback" not in stderr, stderr
    for word in words:
        assert word in stderr, (word, stderr)
    assert snapshot(cwd) == before
    return stderr
