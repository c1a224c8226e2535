"""Handing freed heap memory back to the operating system.

A process that builds and drops many MuJoCo models (each env reset builds a fresh cell) leaves
glibc's heap holding the freed model and data buffers: the resident set grows over hundreds of
resets though nothing leaks (``scripts/soak_env.py`` shows it). Trimming
the heap when a cell is dropped keeps it flat.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
from collections.abc import Callable


@functools.cache
def _malloc_trim() -> Callable[[int], int] | None:
    """glibc's ``malloc_trim``, or None on a C library without it (musl, macOS)."""
    name = ctypes.util.find_library("c")
    if name is None:
        return None
    try:
        return ctypes.CDLL(name).malloc_trim
    except (OSError, AttributeError):
        return None


def return_freed_memory() -> bool:
    """Ask the C allocator to give its free heap pages back; False where the C library cannot.

    Cheap when little is free. No ``gc.collect`` here: it costs far more than the trim with a
    cell in memory, and objects that only a cycle holds are freed by the collector's
    own runs and handed back at the next call.

    Example:
        >>> import mujoco
        >>> model = mujoco.MjModel.from_xml_string("<mujoco/>")
        >>> del model  # a dropped cell
        >>> freed = return_freed_memory()  # True on glibc
    """
    trim = _malloc_trim()
    if trim is None:
        return False
    trim(0)
    return True
