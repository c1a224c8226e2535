"""Where a command's wall time goes: named parts, each timed where the code runs it, while a
:class:`Profile` is on; nearly free while none is (one global read a call).

A part's time leaves out the parts timed inside it, so the parts and the untimed rest add
up to the whole. Parts are marked with :func:`part` (a ``with`` block) or :func:`timed` (a
function or method).

Example:
    >>> profile = Profile(parts=("build", "solve"))
    >>> with profile.on():
    ...     with part("build"):
    ...         with part("solve"):  # the solve's time is not the build's
    ...             pass
    >>> profile.stop()
    >>> profile.calls
    {'build': 1, 'solve': 1}
    >>> abs(sum(profile.seconds_by_part().values()) - profile.total_s()) < 1e-9
    True
"""

from __future__ import annotations

import functools
import os
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager, nullcontext
from pathlib import Path
from types import FunctionType
from typing import Any, TypeVar

#: The row for the time no part claims.
REST = "rest (untimed)"

_Function = TypeVar("_Function", bound=Callable[..., Any])
_Class = TypeVar("_Class", bound=type)
_OFF = nullcontext()
_active: Profile | None = None
_IMPORTED_S = time.perf_counter()


def process_start_s() -> float:
    """When this process started, on :func:`time.perf_counter`'s clock (Linux: from
    ``/proc``, to a clock tick; elsewhere: when this module was imported)."""
    stat = Path("/proc/self/stat")
    if not stat.exists() or not hasattr(time, "CLOCK_BOOTTIME"):
        return _IMPORTED_S
    # The fields after the command name (which may hold spaces); the start is field 22.
    fields = stat.read_text().rsplit(")", 1)[1].split()
    age_s = (time.clock_gettime(time.CLOCK_BOOTTIME)
             - int(fields[19]) / os.sysconf("SC_CLK_TCK"))
    return time.perf_counter() - age_s


class Profile:
    """Wall time by part, s, and calls, from ``started_s`` (a :func:`time.perf_counter`
    reading; default now) to :meth:`stop` (default: now).

    Attributes:
        seconds: each part's own time, s (the parts inside it left out).
        calls: how often each part ran.
        details: figures that split a part further (e.g. MuJoCo's own timers of its step),
            s by name under the part's name; they are inside the part, not added to it.

    Example:
        >>> profile = Profile()
        >>> with profile.on():
        ...     with part("work"):
        ...         pass
        >>> profile.stop()
        >>> [row["part"] for row in profile.rows()]
        ['work', 'rest (untimed)']
    """

    def __init__(self, parts: tuple[str, ...] = (), started_s: float | None = None) -> None:
        self.started_s = time.perf_counter() if started_s is None else started_s
        self.stopped_s: float | None = None
        self.seconds = dict.fromkeys(parts, 0.0)
        self.calls = dict.fromkeys(parts, 0)
        self.details: dict[str, dict[str, float]] = {}
        self._open: list[list[Any]] = []  # [part, start s, time of the parts inside, s]

    def add(self, name: str, seconds: float, calls: int = 1) -> None:
        """Count ``seconds`` of ``name`` measured elsewhere."""
        self.seconds[name] = self.seconds.get(name, 0.0) + seconds
        self.calls[name] = self.calls.get(name, 0) + calls

    def enter(self, name: str) -> None:
        """Start timing ``name`` (a part inside the one now open)."""
        self._open.append([name, time.perf_counter(), 0.0])

    def exit(self) -> None:
        """Stop timing the part entered last."""
        name, start_s, inside_s = self._open.pop()
        elapsed_s = time.perf_counter() - start_s
        self.add(name, elapsed_s - inside_s)
        if self._open:
            self._open[-1][2] += elapsed_s

    def stop(self) -> None:
        """Fix the end of the whole at now."""
        self.stopped_s = time.perf_counter()

    def total_s(self) -> float:
        """The whole's wall time, s."""
        end_s = time.perf_counter() if self.stopped_s is None else self.stopped_s
        return end_s - self.started_s

    def seconds_by_part(self) -> dict[str, float]:
        """Each part's time and the untimed rest, s: they add up to :meth:`total_s`."""
        rest_s = self.total_s() - sum(self.seconds.values())
        return {**self.seconds, REST: rest_s}

    def rows(self) -> list[dict[str, Any]]:
        """The table's rows: part, s, share of the whole, calls; each part's details after
        it (``detail_of`` names the part)."""
        total_s = self.total_s()
        rows: list[dict[str, Any]] = []
        for name, seconds in self.seconds_by_part().items():
            rows.append({"part": name, "s": seconds, "share": seconds / total_s,
                         "calls": self.calls.get(name)})
            rows += [{"part": detail, "s": value, "share": value / total_s, "calls": None,
                      "detail_of": name} for detail, value in self.details.get(name, {}).items()]
        return rows

    def table(self) -> str:
        """The rows as text: a part's details indented under it, the total last."""
        lines = [f"{'part':<40} {'wall s':>9} {'share':>7} {'calls':>7}"]
        for row in self.rows():
            name = ("  " + row["part"]) if "detail_of" in row else row["part"]
            calls = "" if row["calls"] is None else str(row["calls"])
            lines.append(f"{name:<40} {row['s']:>9.3f} {row['share']:>7.1%} {calls:>7}")
        lines.append(f"{'total':<40} {self.total_s():>9.3f} {1.0:>7.1%}")
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: ``total_s``, ``parts_s`` (with the rest; they add up to the total),
        ``calls`` and ``details_s``."""
        return {"total_s": self.total_s(), "parts_s": self.seconds_by_part(),
                "calls": dict(self.calls), "details_s": self.details}

    @contextmanager
    def on(self) -> Iterator[Profile]:
        """This profile counts the parts run inside the block (one profile at a time)."""
        global _active
        previous, _active = _active, self
        try:
            yield self
        finally:
            _active = previous


class _Timing:
    __slots__ = ("name", "profile")

    def __init__(self, profile: Profile, name: str) -> None:
        self.profile, self.name = profile, name

    def __enter__(self) -> None:
        self.profile.enter(self.name)

    def __exit__(self, *exc: object) -> None:
        self.profile.exit()


def part(name: str) -> AbstractContextManager[None]:
    """A ``with`` block timed as ``name`` in the profile that is on (none: nothing done)."""
    return _OFF if _active is None else _Timing(_active, name)


def timed(name: str) -> Callable[[_Function], _Function]:
    """Decorator: each call of the function timed as part ``name`` (:func:`part`)."""
    def decorate(function: _Function) -> _Function:
        @functools.wraps(function)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            profile = _active
            if profile is None:
                return function(*args, **kwargs)
            profile.enter(name)
            try:
                return function(*args, **kwargs)
            finally:
                profile.exit()
        return wrapper  # type: ignore[return-value]
    return decorate


def timed_methods(name: str) -> Callable[[_Class], _Class]:
    """Class decorator: the class's own public methods and ``__init__`` :func:`timed` as
    part ``name``."""
    def decorate(cls: _Class) -> _Class:
        for attribute, value in list(vars(cls).items()):
            if isinstance(value, FunctionType) and (attribute == "__init__"
                                                   or not attribute.startswith("_")):
                setattr(cls, attribute, timed(name)(value))
        return cls
    return decorate
