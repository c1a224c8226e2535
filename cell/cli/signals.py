"""Stop signals as exceptions: SIGTERM (and SIGHUP) raise :class:`~cell.errors.Stopped`, as
Ctrl-C raises :class:`KeyboardInterrupt`, so that every ``finally`` on the way out removes
its temporary files before the process ends.

An exception raised where Python cannot pass it on (inside a C library's callback into
Python, such as the JIT compiler's) is dropped and reported as "unraisable": a stop that
lands there is sent again, so that it is raised once more where it can travel.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

from cell.errors import Stopped

#: The signals that stop a command cleanly (SIGINT is Python's own KeyboardInterrupt).
STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)


def _raise_stopped(number: int, frame: FrameType | None) -> None:
    raise Stopped(number)


@contextmanager
def stop_signals_raise() -> Iterator[None]:
    """Within the block, a stop signal raises :class:`~cell.errors.Stopped` (and a stop
    dropped in a callback is sent again); the handlers that were set before come back after.

    Example:
        >>> with stop_signals_raise():
        ...     try:
        ...         signal.raise_signal(signal.SIGTERM)
        ...     except Stopped as stop:
        ...         print(stop.exit_code)
        143
    """
    previous = {number: signal.signal(number, _raise_stopped) for number in STOP_SIGNALS}
    previous_hook = sys.unraisablehook

    def send_again(unraisable: sys.UnraisableHookArgs) -> None:
        stop = unraisable.exc_value
        if isinstance(stop, Stopped | KeyboardInterrupt):
            number = stop.signal_number if isinstance(stop, Stopped) else signal.SIGINT
            # From another thread, so that the handler does not run inside this hook, where
            # its exception would be dropped again, but in the main thread's next bytecode.
            threading.Timer(0.01, os.kill, (os.getpid(), number)).start()
        else:
            previous_hook(unraisable)

    sys.unraisablehook = send_again
    try:
        yield
    finally:
        sys.unraisablehook = previous_hook
        for number, handler in previous.items():
            signal.signal(number, handler)
