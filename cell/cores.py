"""How many processes a command runs side by side when its ``--workers`` is not given: one
per core this process may use, or ``MUSCLECELL_WORKERS`` where set (a shared machine, a
container's share of a larger one, a test run that already keeps every core busy). Only work
whose result does not depend on the count follows it: a diagnosis, an evaluation, a bench's
sets, never ``learn``'s envs.
"""

from __future__ import annotations

import os

from cell.errors import InputError

#: The environment variable that sets the default count of worker processes.
WORKERS_VARIABLE = "MUSCLECELL_WORKERS"


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity where the platform has one).

    Example:
        >>> usable_cores() >= 1
        True
    """
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def default_workers(at_once: int = 1) -> int:
    """``MUSCLECELL_WORKERS`` where set, else the more of :func:`usable_cores` and
    ``at_once``: the tasks each step of the work waits for together (a batch's logs, replayed
    in one world). Processes beyond the cores share them, and such a step then ends when its
    CPU is spent, not a round of replays later.

    Raises:
        InputError: the variable is set to anything but a whole number >= 1.

    Example:
        >>> import os
        >>> os.environ["MUSCLECELL_WORKERS"] = "3"
        >>> default_workers()
        3
        >>> del os.environ["MUSCLECELL_WORKERS"]
    """
    text = os.environ.get(WORKERS_VARIABLE, "").strip()
    if not text:
        return max(usable_cores(), at_once)
    if not text.isdigit() or int(text) < 1:
        raise InputError(None, WORKERS_VARIABLE,
                         f"must be a whole number >= 1, got {text!r}")
    return int(text)
