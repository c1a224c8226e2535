"""Progress on standard error: the one bar every long command shows (``--quiet`` drops it),
so that standard output keeps only the command's result.

Example:
    >>> with progress_bar("set", quiet=True, total=3) as bar:
    ...     for _ in range(3):
    ...         bar.update()
    >>> [k for k in progress_bar("step", quiet=True, iterable=range(3))]
    [0, 1, 2]
"""

from __future__ import annotations

import sys
from collections.abc import Iterable
from typing import Any

from tqdm import tqdm


def progress_bar(unit: str, *, quiet: bool, total: float | None = None,
                 iterable: Iterable[Any] | None = None, desc: str | None = None,
                 initial: float = 0) -> tqdm:
    """A bar on stderr of ``total`` steps of ``unit`` (``initial`` of them done already), or
    over ``iterable``; silent when ``quiet``. A context manager advanced by ``update(n)``, or
    an iterable that advances as it is read."""
    return tqdm(iterable, total=total, initial=initial, unit=unit, desc=desc, disable=quiet,
                file=sys.stderr, dynamic_ncols=True)
