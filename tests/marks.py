"""Which parameters of a test the default run keeps: the others run with ``-m slow``, so that
the default suite stays under CI's ten minutes while every case still has a run that checks it."""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterable
from typing import Any

import pytest


def slow_but(kept: Collection[Any], values: Iterable[Any],
             ids: Callable[[Any], str] | None = None) -> list[Any]:
    """``values`` as pytest parameters, every one not in ``kept`` marked ``slow``.

    Example:
        >>> [p.marks for p in slow_but({1}, [1, 2])]
        [(), (MarkDecorator(mark=Mark(name='slow', args=(), kwargs={})),)]
    """
    return [pytest.param(value, id=ids(value) if ids else None,
                         marks=() if value in kept else pytest.mark.slow)
            for value in values]
