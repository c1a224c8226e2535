"""How the docs run: the snippet convention of README.md and docs/*.md, its parser and runner.

The convention every page follows:

- fenced ``bash`` and ``python`` blocks run; other languages (``toml``, ``text``,
  ``console``, ...) are shown, not run;
- the blocks of one page run in order, each in a process of its own, in one temporary working
  folder that holds symbolic links to the project's top-level entries (``scenarios``,
  ``assets``, ``scripts``, ``.venv``, ...), so a command written from the project's root works
  there and what it writes (``out/...``) lands in that folder; files carry from one block to
  the next, Python variables do not;
- ``bash`` blocks run with ``bash -euo pipefail`` and the virtual environment's ``bin`` first on
  ``PATH``; ``python`` blocks run with ``python -c`` of this interpreter;
- HTML comments on the lines just before a fence control it:
  ``<!-- test: slow -->`` runs the block only under ``-m slow``;
  ``<!-- test: replace "A" "B" -->`` (one per line, as many as needed) runs it with that text
  replaced, the shortened form of a long run; each "A" must occur in the block;
  ``<!-- test: skip REASON -->`` never runs it (``bash scripts/test.sh`` itself, which CI
  runs, and the like), and says why.

tests/test_docs.py runs one test per page on its default blocks and, for pages with slow
blocks, a second test, marked slow, that runs all their blocks in order.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
RUN_LANGUAGES = ("bash", "python")
BLOCK_TIMEOUT_S = 1800.0
OUTPUT_TAIL_LINES = 80
# Top-level entries a page's working folder does not link: the snippets' outputs land in that
# folder, not in the project's; history and caches stay out.
NOT_LINKED = frozenset(
    {".git", "out", "build", ".pytest_cache", ".ruff_cache", "__pycache__", "MUJOCO_LOG.TXT"}
)

_FENCE_OPEN = re.compile(r"^(?P<indent>\s*)(?P<fence>`{3,}|~{3,})\s*(?P<info>[^`]*?)\s*$")
_DIRECTIVE = re.compile(r"^\s*<!--\s*test:\s*(?P<body>.*?)\s*-->\s*$")


class SnippetSyntaxError(ValueError):
    """A page breaks the snippet convention: an unclosed fence, an unknown or misplaced
    ``<!-- test: ... -->`` directive, or a replacement whose text is not in its block."""


@dataclass(frozen=True)
class Snippet:
    """One fenced block of a page, with the directives written just before it.

    Attributes:
        page: the page's name, as failures show it.
        line: the line of the opening fence, counted from 1.
        language: the fence's language (the first word of its info string), or ``""``.
        code: the block's text, without the fences.
        slow: runs only under ``-m slow``.
        skip_reason: why the block never runs (``None``: it runs; ``""``: skipped, no reason).
        replacements: the ``(old, new)`` texts replaced before it runs, in order.

    Example:
        >>> Snippet("page.md", 3, "bash", "echo hi\\n").runs
        True
    """

    page: str
    line: int
    language: str
    code: str
    slow: bool = False
    skip_reason: str | None = None
    replacements: tuple[tuple[str, str], ...] = ()

    @property
    def runs(self) -> bool:
        """Whether the block is run at all (its language, and no skip)."""
        return self.language in RUN_LANGUAGES and self.skip_reason is None

    def source(self) -> str:
        """The code that runs: the block with its replacements made."""
        code = self.code
        for old, new in self.replacements:
            if old not in code:
                raise SnippetSyntaxError(
                    f"{self.page}:{self.line}: replace {old!r}: the block has no such text"
                )
            code = code.replace(old, new)
        return code


def _apply_directive(body: str, where: str, options: dict) -> None:
    word, _, rest = body.partition(" ")
    rest = rest.strip()
    if word == "slow" and not rest:
        options["slow"] = True
    elif word == "skip":
        options["skip_reason"] = rest
    elif word == "replace":
        try:
            texts = shlex.split(rest)
        except ValueError as error:
            raise SnippetSyntaxError(f"{where}: replace: {error}") from error
        if len(texts) != 2:
            raise SnippetSyntaxError(f'{where}: replace takes two quoted texts, "A" "B": {body!r}')
        options["replacements"].append((texts[0], texts[1]))
    else:
        raise SnippetSyntaxError(f"{where}: unknown directive <!-- test: {body} -->")


def parse_snippets(text: str, page: str) -> list[Snippet]:
    """The fenced blocks of a Markdown page, in order, each with its directives.

    Raises:
        SnippetSyntaxError: a fence is never closed, or a directive is unknown or stands
            anywhere but on the lines just before a fence.

    Example:
        >>> page = '<!-- test: slow -->\\n```bash\\necho hi\\n```\\n'
        >>> [(s.line, s.language, s.slow) for s in parse_snippets(page, "page.md")]
        [(2, 'bash', True)]
    """
    lines = text.splitlines()
    snippets: list[Snippet] = []
    directive_lines: dict[int, str] = {}
    index = 0
    while index < len(lines):
        directive = _DIRECTIVE.match(lines[index])
        if directive:
            directive_lines[index] = directive["body"]
            index += 1
            continue
        opening = _FENCE_OPEN.match(lines[index])
        if not opening:
            index += 1
            continue
        fence, indent = opening["fence"], len(opening["indent"])
        closing = re.compile(rf"^\s*{re.escape(fence[0])}{{{len(fence)},}}\s*$")
        end = index + 1
        while end < len(lines) and not closing.match(lines[end]):
            end += 1
        if end == len(lines):
            raise SnippetSyntaxError(f"{page}:{index + 1}: the fence opened here is never closed")
        options: dict = {"slow": False, "skip_reason": None, "replacements": []}
        above = index - 1
        while above in directive_lines:
            above -= 1
        for number in range(above + 1, index):
            _apply_directive(directive_lines.pop(number), f"{page}:{number + 1}", options)
        # A fence indented in a list item: its lines lose that indentation, no more.
        body = [line[min(indent, len(line) - len(line.lstrip())):]
                for line in lines[index + 1:end]]
        snippets.append(Snippet(
            page=page,
            line=index + 1,
            language=opening["info"].split()[0] if opening["info"] else "",
            code="\n".join(body) + "\n",
            slow=options["slow"],
            skip_reason=options["skip_reason"],
            replacements=tuple(options["replacements"]),
        ))
        index = end + 1
    if directive_lines:
        number = min(directive_lines)
        raise SnippetSyntaxError(
            f"{page}:{number + 1}: <!-- test: {directive_lines[number]} --> does not stand on "
            "the lines just before a fence"
        )
    return snippets


def page_name(page: Path) -> str:
    """The page's path from the project's root, as tests and failures name it."""
    resolved = page.resolve()
    return resolved.relative_to(ROOT).as_posix() if resolved.is_relative_to(ROOT) else str(page)


def read_snippets(page: Path) -> list[Snippet]:
    """The fenced blocks of a page file (:func:`parse_snippets`)."""
    return parse_snippets(page.read_text(encoding="utf-8"), page_name(page))


def link_project(workdir: Path, root: Path = ROOT) -> None:
    """Fill a page's working folder with links to the project's top-level entries."""
    for entry in sorted(root.iterdir()):
        if entry.name not in NOT_LINKED and not (workdir / entry.name).exists():
            (workdir / entry.name).symlink_to(entry)


def _snippet_environment() -> dict[str, str]:
    environment = dict(os.environ)
    environment.setdefault("MUJOCO_GL", "egl")
    environment["PATH"] = os.pathsep.join([str(Path(sys.executable).parent),
                                           environment.get("PATH", "")])
    return environment


def _command(snippet: Snippet) -> list[str]:
    code = snippet.source()
    if snippet.language == "bash":
        return ["bash", "-euo", "pipefail", "-c", code]
    return [sys.executable, "-c", code]


def run_snippets(snippets: list[Snippet], workdir: Path, slow: bool) -> list[tuple[Snippet, float]]:
    """Run a page's blocks in order in ``workdir``, the slow ones too if ``slow``; stop at the
    first that fails, with the page, the block's line and its output.

    Returns:
        Each block that ran with its wall time, s.
    """
    environment = _snippet_environment()
    timings: list[tuple[Snippet, float]] = []
    for snippet in snippets:
        if not snippet.runs or (snippet.slow and not slow):
            continue
        start = time.perf_counter()
        try:
            done = subprocess.run(
                _command(snippet), cwd=workdir, env=environment, stdin=subprocess.DEVNULL,
                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                timeout=BLOCK_TIMEOUT_S, check=False,
            )
            output, failure = done.stdout, (f"exit status {done.returncode}"
                                             if done.returncode else None)
        except subprocess.TimeoutExpired as expired:
            output = expired.stdout if isinstance(expired.stdout, str) else ""
            failure = f"still running after {BLOCK_TIMEOUT_S:.0f} s"
        timings.append((snippet, time.perf_counter() - start))
        if failure:
            tail = "\n".join(output.splitlines()[-OUTPUT_TAIL_LINES:])
            pytest.fail(
                f"{snippet.page}:{snippet.line}: the {snippet.language} block failed "
                f"({failure}) in {workdir}\n--- block ---\n{snippet.source()}"
                f"--- output (last {OUTPUT_TAIL_LINES} lines) ---\n{tail}",
                pytrace=False,
            )
    return timings


def run_page(page: Path, workdir: Path, slow: bool) -> list[tuple[Snippet, float]]:
    """Run one page's blocks (:func:`run_snippets`) in a working folder linked to the project."""
    link_project(workdir)
    return run_snippets(read_snippets(page), workdir, slow)
