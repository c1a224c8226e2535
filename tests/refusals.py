"""The command line's promise for bad input, as one check: exit 2 naming file and key, no
traceback, and the working folder (the output folder in it) left as it was."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path


def snapshot(folder: Path) -> dict[str, str]:
    """Every entry under ``folder`` by relative path: a folder, or its file's hash."""
    entries = {}
    for path in sorted(folder.rglob("*")):
        key = path.relative_to(folder).as_posix()
        entries[key] = "folder" if path.is_dir() else hashlib.sha256(path.read_bytes()
                                                                     ).hexdigest()
    return entries


def refused(cwd: Path, *args: str, words: tuple[str, ...], code: int = 2) -> str:
    """Run ``musclecell ARGS`` in ``cwd``; check that it exits ``code`` naming each of
    ``words`` without a traceback, and leaves ``cwd`` as it was; return the
    message."""
    before = snapshot(cwd)
    result = subprocess.run([sys.executable, "-m", "cell.cli", *args], cwd=cwd, timeout=300,
                            capture_output=True, text=True,
                            env={**os.environ, "MUJOCO_GL": "egl"})
    assert result.returncode == code, result.stderr
    assert "Traceback" not in result.stderr, result.stderr
    for word in words:
        assert word in result.stderr, (word, result.stderr)
    assert snapshot(cwd) == before
    return result.stderr
