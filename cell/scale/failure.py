"""What a run that failed records: its error in one line for the table, the end of its
traceback for whoever debugs it."""

from __future__ import annotations

import traceback

#: Lines of a failed run's traceback kept in its record.
TRACEBACK_LINES = 12


def describe_failure(error: BaseException) -> tuple[str, str]:
    """The error's type and message, and the last lines of its traceback; call it while
    handling ``error``.

    Example:
        >>> try:
        ...     raise ValueError("no meat")
        ... except ValueError as exc:
        ...     message, trace = describe_failure(exc)
        >>> message, trace.splitlines()[-1]
        ('ValueError: no meat', 'ValueError: no meat')
    """
    lines = traceback.format_exc().splitlines(keepends=True)[-TRACEBACK_LINES:]
    return f"{type(error).__name__}: {error}", "".join(lines)
