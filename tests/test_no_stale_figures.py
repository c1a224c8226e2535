"""No measured figure goes stale in the code: comments and docstrings of the library hold no
timing (a number in ns or us), no speed against real time, and no figure of a named seed.
Those figures live, dated and with their command, on ``docs/benchmarks.md``.

Code examples are code, not prose: doctest lines (``>>>``, ``...`` and the output under them),
the indented block after a line ending in ``::``, and inline ````literals````.
"""

from __future__ import annotations

import ast
import io
import re
import tokenize
from pathlib import Path

from tests.paths import PROJECT_ROOT

#: What a stale figure looks like, by name.
PATTERNS = {
    "timing": re.compile(r"\b\d+(?:\.\d+)?(?:e[-+]?\d+)?\s*(?:ns|us|µs)\b", re.IGNORECASE),
    "real time": re.compile(r"\b\d+(?:\.\d+)?\s*(?:x|\u00d7|times)\s+real[- ]time\b",
                            re.IGNORECASE),
    "seed": re.compile(r"\bseeds?\s+\d+", re.IGNORECASE),
}
_INLINE_LITERAL = re.compile(r"``.*?``")


def _prose_lines(text: str) -> list[tuple[int, str]]:
    """(offset, line) of the lines of a docstring that are prose, not a code example."""
    prose = []
    in_doctest = False
    literal_indent: int | None = None
    opens_literal = False
    for offset, line in enumerate(text.splitlines()):
        stripped = line.strip()
        indent = len(line) - len(line.lstrip())
        if literal_indent is not None and stripped and indent <= literal_indent:
            literal_indent = None
        if opens_literal and stripped:
            opens_literal = False
        if stripped.startswith((">>>", "...")):
            in_doctest = True
        elif not stripped:
            in_doctest = False
        if stripped.endswith("::"):
            literal_indent, opens_literal = indent, True
        if in_doctest or (literal_indent is not None and indent > literal_indent):
            continue
        prose.append((offset, _INLINE_LITERAL.sub("``code``", line)))
    return prose


def _chunks(lines: list[tuple[int, str]]) -> list[tuple[int, list[str]]]:
    """Runs of consecutive lines, (first line number, lines): a figure may break a line."""
    chunks: list[tuple[int, list[str]]] = []
    for number, text in lines:
        if chunks and chunks[-1][0] + len(chunks[-1][1]) == number:
            chunks[-1][1].append(text)
        else:
            chunks.append((number, [text]))
    return chunks


def stale_figures(path: Path, root: Path) -> list[str]:
    """Every stale figure in ``path``'s comments and string statements (docstrings, also those
    of module attributes), as ``file:line: kind 'match': the line``."""
    source = path.read_text()
    comments = [(token.start[0], token.string)
                for token in tokenize.generate_tokens(io.StringIO(source).readline)
                if token.type == tokenize.COMMENT]
    chunks = _chunks(comments)
    for node in ast.walk(ast.parse(source)):
        if (isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)
                and isinstance(node.value.value, str)):
            chunks += _chunks([(node.lineno + offset, line)
                               for offset, line in _prose_lines(node.value.value)])
    found = []
    for first, lines in sorted(chunks):
        text = "\n".join(lines)
        for kind, pattern in PATTERNS.items():
            for match in pattern.finditer(text):
                row = text.count("\n", 0, match.start())
                found.append(f"{path.relative_to(root)}:{first + row}: {kind} "
                             f"{' '.join(match.group(0).split())!r}: {lines[row].strip()}")
    return found


def library_stale_figures(root: Path) -> list[str]:
    """Every stale figure in ``cell/``, ``envs/`` and ``controllers/`` under ``root``."""
    return [figure for top in ("cell", "envs", "controllers")
            for path in sorted((root / top).rglob("*.py"))
            for figure in stale_figures(path, root)]


def test_the_library_holds_no_stale_figure() -> None:
    assert library_stale_figures(PROJECT_ROOT) == []


def test_a_stale_figure_is_caught(tmp_path: Path) -> None:
    (tmp_path / "cell").mkdir()
    (tmp_path / "cell" / "law.py").write_text(
        '"""The spring law: 12 ns per spring.\n\n'
        "Example:\n"
        "    >>> run(seed 3)  # doctest lines are code\n"
        "    seed 3\n\n"
        "Usage::\n\n"
        "    bench --seeds 5   # a literal block is code too\n\n"
        'Run ``musclecell run --seed 4`` to repeat; seeds 50000-50009 tuned it.\n"""\n'
        "STEP = 1  # 3.4x real time on the default meat, 2.5 us a node\n"
        'LIMIT = 2\n"""Reached at 2 times\nreal-time; used by 12 users."""\n')
    assert library_stale_figures(tmp_path) == [
        "cell/law.py:1: timing '12 ns': The spring law: 12 ns per spring.",
        "cell/law.py:11: seed 'seeds 50000': Run ``code`` to repeat; seeds 50000-50009 tuned it.",
        "cell/law.py:13: timing '2.5 us': # 3.4x real time on the default meat, 2.5 us a node",
        "cell/law.py:13: real time '3.4x real time': "
        "# 3.4x real time on the default meat, 2.5 us a node",
        "cell/law.py:15: real time '2 times real-time': Reached at 2 times",
    ]
