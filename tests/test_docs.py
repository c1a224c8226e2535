"""The docs run: every snippet of README.md and docs/*.md, and the docs site's own checks.

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

One test per page runs its default blocks; pages with slow blocks have a second test, marked
slow, that runs all their blocks in order.
"""

from __future__ import annotations

import importlib
import os
import pkgutil
import re
import shlex
import subprocess
import sys
import time
import zlib
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
RUN_LANGUAGES = ("bash", "python")
README_MAX_LINES = 150
API_PACKAGES = ("cell", "envs", "controllers")
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


PAGES = sorted([ROOT / "README.md", *DOCS.glob("*.md")])


def _has_slow_blocks(page: Path) -> bool:
    try:
        return any(snippet.slow and snippet.runs for snippet in read_snippets(page))
    except SnippetSyntaxError:
        return True  # collected, so that the slow test shows the error too


@pytest.mark.parametrize("page", PAGES, ids=page_name)
def test_the_pages_snippets_run(page: Path, tmp_path: Path) -> None:
    run_page(page, tmp_path, slow=False)


@pytest.mark.slow
@pytest.mark.parametrize("page", [page for page in PAGES if _has_slow_blocks(page)],
                         ids=page_name)
def test_the_pages_snippets_run_with_the_slow_ones(page: Path, tmp_path: Path) -> None:
    run_page(page, tmp_path, slow=True)


def test_every_skipped_snippet_says_why() -> None:
    unexplained = [f"{snippet.page}:{snippet.line}" for page in PAGES
                   for snippet in read_snippets(page) if snippet.skip_reason == ""]
    assert not unexplained, f"<!-- test: skip --> without a reason at {unexplained}"


def test_the_readme_is_a_front_page() -> None:
    lines = len((ROOT / "README.md").read_text(encoding="utf-8").splitlines())
    assert lines <= README_MAX_LINES, (
        f"README.md has {lines} lines, more than {README_MAX_LINES}: "
        "the rest belongs on a docs page")


def _toctree_entries(page: Path) -> list[str]:
    """The documents a page's ``{toctree}`` blocks list (their own names, without ``.md``)."""
    entries = []
    for snippet in read_snippets(page):
        if snippet.language == "{toctree}":
            entries += [line.strip().removesuffix(".md") for line in snippet.code.splitlines()
                        if line.strip() and not line.strip().startswith(":")]
    return entries


def test_every_docs_page_is_in_the_sites_table_of_contents() -> None:
    reached, queue = {"index"}, ["index"]
    while queue:
        for entry in _toctree_entries(DOCS / f"{queue.pop()}.md"):
            if entry not in reached and (DOCS / f"{entry}.md").exists():
                reached.add(entry)
                queue.append(entry)
    pages = {page.stem for page in DOCS.glob("*.md")}
    assert pages <= reached, f"docs pages no toctree reaches from index.md: {pages - reached}"


def public_modules(package: str) -> list[str]:
    """The package and every module under it whose dotted name has no ``_``-prefixed part."""
    module = importlib.import_module(package)
    names = [package] + [info.name for info in pkgutil.walk_packages(module.__path__,
                                                                      f"{package}.")]
    return [name for name in names
            if not any(part.startswith("_") for part in name.split("."))]


def documented_modules(site: Path) -> set[str]:
    """The ``py:module`` entries of a built site's Sphinx inventory (``objects.inv``)."""
    raw = (site / "objects.inv").read_bytes()
    header_end = 0
    for _ in range(4):  # four text lines, then the zlib-compressed entries
        header_end = raw.index(b"\n", header_end) + 1
    entries = zlib.decompress(raw[header_end:]).decode("utf-8").splitlines()
    return {line.split(" ", 1)[0] for line in entries if " py:module " in line}


@pytest.fixture(scope="module")
def built_site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The docs site scripts/test.sh built (``MUSCLECELL_DOCS_SITE``), or a fresh build."""
    given = os.environ.get("MUSCLECELL_DOCS_SITE")
    if given and (Path(given) / "objects.inv").exists():
        return Path(given)
    site = tmp_path_factory.mktemp("site")
    build = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
         str(DOCS), str(site)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, check=False,
    )
    assert build.returncode == 0, f"the docs site does not build:\n{build.stdout[-8000:]}"
    return site


def test_the_api_reference_covers_every_public_module(built_site: Path) -> None:
    modules = [name for package in API_PACKAGES for name in public_modules(package)]
    missing = sorted(set(modules) - documented_modules(built_site))
    assert not missing, f"modules without a page in the API reference: {missing}"


_EXAMPLE_PAGE = """\
# A page

```toml
[shown] = "not run"
```

<!-- test: replace "steps 1000" "steps 2" -->
<!-- test: replace "hello" "bye" -->
```bash
echo "hello, steps 1000" > out.txt
```

<!-- test: slow -->
```python
from pathlib import Path
for name in ["out.txt"]:
    assert Path(name).read_text() == "bye, steps 2\\n"
```

<!-- test: skip CI runs it -->
```bash
exit 1
```

- in a list:

  ```python
  print(open("out.txt").read())
  ```
"""


def test_the_parser_reads_fences_and_directives() -> None:
    snippets = parse_snippets(_EXAMPLE_PAGE, "example.md")
    assert [(s.line, s.language, s.runs, s.slow) for s in snippets] == [
        (3, "toml", False, False), (9, "bash", True, False), (14, "python", True, True),
        (21, "bash", False, False), (27, "python", True, False),
    ]
    assert snippets[1].replacements == (("steps 1000", "steps 2"), ("hello", "bye"))
    assert snippets[1].source() == 'echo "bye, steps 2" > out.txt\n'
    assert snippets[3].skip_reason == "CI runs it"
    assert snippets[2].code.splitlines()[1] == "for name in [\"out.txt\"]:"
    assert snippets[2].code.splitlines()[2].startswith("    assert")
    assert snippets[4].code == 'print(open("out.txt").read())\n'


def test_the_parser_refuses_what_would_silently_not_run() -> None:
    with pytest.raises(SnippetSyntaxError, match="unknown directive"):
        parse_snippets("<!-- test: sloww -->\n```bash\ntrue\n```\n", "a.md")
    with pytest.raises(SnippetSyntaxError, match=r"a\.md:1:.*just before a fence"):
        parse_snippets("<!-- test: slow -->\n\n```bash\ntrue\n```\n", "a.md")
    with pytest.raises(SnippetSyntaxError, match="never closed"):
        parse_snippets("```bash\ntrue\n", "a.md")
    with pytest.raises(SnippetSyntaxError, match="no such text"):
        parse_snippets('<!-- test: replace "x" "y" -->\n```bash\ntrue\n```\n', "a.md")[0].source()
    skipped = parse_snippets("<!-- test: skip -->\n```bash\ntrue\n```\n", "a.md")[0]
    assert skipped.skip_reason == ""


def test_a_pages_blocks_share_one_working_folder(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text(_EXAMPLE_PAGE)
    workdir = tmp_path / "work"
    workdir.mkdir()
    ran = run_page(page, workdir, slow=True)
    assert [snippet.line for snippet, _ in ran] == [9, 14, 27]
    assert (workdir / "scenarios").resolve() == ROOT / "scenarios"
    assert not (ROOT / "out.txt").exists()


def test_a_failing_block_names_its_page_and_line(tmp_path: Path) -> None:
    snippets = parse_snippets("# A\n\n```python\nraise SystemExit('broken here')\n```\n",
                              "broken.md")
    with pytest.raises(pytest.fail.Exception, match=r"(?s)broken\.md:3: .*broken here"):
        run_snippets(snippets, tmp_path, slow=False)
