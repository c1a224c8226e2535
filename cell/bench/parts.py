"""A suite's entries measured one after another, a progress line as each one finishes, so
that a suite running for minutes says where it is (``--quiet`` drops the lines).

Example:
    >>> lines = []
    >>> measured({"one": lambda: {"value": 1.0}, "two": lambda: {"value": 2.0}}, lines.append)
    {'one': {'value': 1.0}, 'two': {'value': 2.0}}
    >>> lines
    ['bench: one done (1 of 2)', 'bench: two done (2 of 2)']
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

#: Where a suite's progress lines go: a line at a time, or None for nowhere.
Progress = Callable[[str], None] | None


def measured(parts: dict[str, Callable[[], Any]], progress: Progress) -> dict[str, Any]:
    """Each part's result under its name, measured in order; ``progress`` hears of each as
    it finishes."""
    results = {}
    for done, (name, measure) in enumerate(parts.items(), start=1):
        results[name] = measure()
        if progress is not None:
            progress(f"bench: {name} done ({done} of {len(parts)})")
    return results
