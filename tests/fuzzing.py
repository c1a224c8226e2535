"""Shared pieces of the fuzz tests (``tests/test_fuzz_*.py``): Hypothesis strategies of
malformed values and documents, a TOML writer for them, and the two variants every fuzz test
comes in (a short default one, and a ``slow`` one of :data:`SLOW_EXAMPLES` examples).

The property every reader must keep: whatever the input, it returns or raises a
:class:`~cell.errors.MusclecellError`, never a raw exception.
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cell.errors import MusclecellError

#: Examples per reader of the slow variant.
SLOW_EXAMPLES = 10_000
#: Finite and non-finite numbers that break careless code: zero, signs, the extremes, NaN.
NASTY_FLOATS = (math.nan, math.inf, -math.inf, 0.0, -0.0, -1.0, 1e308, -1e308, 5e-324, 1e-300,
                1e30, 1e5, 1e-6)


def numbers() -> st.SearchStrategy[float | int]:
    """Plausible numbers, nasty ones, any float, and integers up to 64 bits."""
    return st.one_of(st.floats(-2.0, 2.0), st.sampled_from(NASTY_FLOATS), st.floats(),
                     st.integers(-(2**63), 2**63 - 1), st.integers(-3, 3))


def words() -> st.SearchStrategy[str]:
    """Short text, including unusual characters."""
    return st.text(max_size=10)


def scalars() -> st.SearchStrategy[Any]:
    """A TOML scalar: a number, a boolean or text."""
    return st.one_of(numbers(), st.booleans(), words())


def values() -> st.SearchStrategy[Any]:
    """A TOML value: a scalar, or lists and tables of them, nested a little."""
    return st.recursive(scalars(), lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(words(), inner, max_size=3)),
        max_leaves=6)


def toml_string(text: str) -> str:
    """``text`` as a TOML basic string: quotes, backslashes and control characters escaped,
    everything else as it is."""
    escaped = "".join("\\" + c if c in '"\\' else f"\\u{ord(c):04x}"
                      if ord(c) < 0x20 or ord(c) == 0x7F else c for c in text)
    return f'"{escaped}"'


def toml_value(value: Any) -> str:
    """``value`` as a TOML value (inline arrays and tables; ``nan``, ``inf`` as TOML has
    them)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{toml_string(k)} = {toml_value(v)}"
                               for k, v in value.items()) + "}"
    raise TypeError(f"no TOML for {value!r}")


def toml_document(document: dict[str, Any]) -> str:
    """``document`` as TOML: its tables as ``[table]`` sections (dotted sub-tables inline),
    its other values at the top."""
    top = [f"{toml_string(k)} = {toml_value(v)}" for k, v in document.items()
           if not isinstance(v, dict)]
    sections = []
    for name, table in document.items():
        if isinstance(table, dict):
            sections.append(f"[{toml_string(name)}]")
            sections += [f"{toml_string(k)} = {toml_value(v)}" for k, v in table.items()]
    return "\n".join(top + sections) + "\n"


def mostly(good: st.SearchStrategy[Any], bad: st.SearchStrategy[Any], odds: int = 10
           ) -> st.SearchStrategy[Any]:
    """``bad`` once in ``odds``, else ``good``: a well-formed input with a fault or two, so
    that the checks past the first fault are reached."""
    # Not an end of the range: Hypothesis draws those far more often.
    return st.integers(1, odds).flatmap(lambda pick: bad if pick == odds // 2 else good)


@st.composite
def documents(draw: st.DrawFn, keys: dict[str, tuple[str, ...]],
              value: Callable[[str, str], st.SearchStrategy[Any]] | None = None
              ) -> dict[str, Any]:
    """A TOML document of some of the tables of ``keys`` (table -> its known keys) and a
    stray one, each with known keys and strays; ``value(table, key)`` draws a value."""
    pick = value or (lambda table, key: values())
    names = draw(st.lists(mostly(st.sampled_from(sorted(keys)), words(), 8), max_size=4,
                          unique=True))
    document: dict[str, Any] = {}
    for name in names:
        if draw(mostly(st.just(False), st.just(True))):
            document[name] = draw(scalars())
            continue
        known = keys.get(name, ()) or ("x",)
        chosen = draw(st.lists(mostly(st.sampled_from(known), words()), max_size=4,
                               unique=True))
        document[name] = {key: draw(pick(name, key)) for key in chosen}
    return document


def check_named(read: Callable[[], object]) -> None:
    """Run ``read``; a :class:`MusclecellError` is a named refusal, anything else a find."""
    with contextlib.suppress(MusclecellError):
        read()


def fuzz_tests(strategy: st.SearchStrategy[Any], check: Callable[[Any], None],
               examples: int, slow_examples: int = SLOW_EXAMPLES
               ) -> tuple[Callable[[], None], Callable[[], None]]:
    """Two tests of ``check`` on ``strategy``'s examples: ``examples`` of them by default, and
    ``slow_examples`` under ``-m slow``. No example database is written."""

    def variant(count: int) -> Callable[[], None]:
        @settings(max_examples=count, deadline=None, database=None,
                  suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                         HealthCheck.filter_too_much])
        @given(strategy)
        def test(case: Any) -> None:
            check(case)

        return test

    return variant(examples), pytest.mark.slow(variant(slow_examples))


def written(folder: Path, files: dict[str, str | bytes]) -> Path:
    """``files`` (name -> text or bytes) written into ``folder``; returns ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, content in files.items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content, encoding="utf-8", errors="surrogatepass")
    return folder


def scratch() -> tempfile.TemporaryDirectory[str]:
    """A temporary folder for one example (Hypothesis runs many per test, so no
    ``tmp_path``)."""
    return tempfile.TemporaryDirectory(prefix="musclecell-fuzz-")


def cells() -> st.SearchStrategy[str]:
    """A CSV cell: a number as text (plausible, nasty, any), a word, or nothing."""
    return st.one_of(numbers().map(repr), st.sampled_from([repr(v) for v in NASTY_FLOATS]),
                     st.sampled_from(["", "nan", "1e", "x"]))


@st.composite
def tables(draw: st.DrawFn, columns: tuple[str, ...], special: dict[str, Any],
           time_column: str) -> str:
    """CSV text with a header of ``columns`` (rarely one dropped, a stray added, shuffled),
    rows of cells (``special``: column -> strategy of cells; times mostly increase), blank
    and comment lines."""
    header = draw(st.permutations(list(columns)))
    if draw(mostly(st.just(False), st.just(True))):
        header = header[:-1]
    if draw(mostly(st.just(False), st.just(True), 5)):
        header = [*header, "note"]
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(header)
    step = draw(st.sampled_from([0.01, 0.5, 30.0]))
    for index in range(draw(st.integers(0, 12))):
        line = draw(mostly(st.just("row"), st.sampled_from(["blank", "comment", "short"])))
        if line == "blank":
            text.write("\n")
        elif line == "comment":
            text.write("# a comment\n")
        else:
            row = [draw(mostly(st.just(repr(index * step)), cells(), 50))
                   if name == time_column else draw(special.get(name, cells()))
                   for name in header]
            writer.writerow(row[:-1] if line == "short" else row)
    return text.getvalue()
