"""MuJoCo's warnings to the standard error stream, and nowhere else.

MuJoCo's default handler prints each warning and appends it to ``MUJOCO_LOG.TXT`` in the
working folder: a command that promises to write only what it was asked would leave that file
behind a diverged run. With a handler of our own installed, MuJoCo writes no log file.
"""

from __future__ import annotations

import sys


def warnings_to_stderr() -> None:
    """Route MuJoCo's warnings to ``sys.stderr`` (replacing any handler set before).

    The simulation reads its warnings from ``MjData.warning``, not from the handler, so what
    counts as a divergence does not change.

    Example:
        >>> warnings_to_stderr()
    """
    import mujoco

    mujoco.set_mju_user_warning(_print_warning)


def _print_warning(message: str) -> None:
    print(f"MuJoCo warning: {message}", file=sys.stderr)
