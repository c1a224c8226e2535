"""The docs run: every snippet of README.md and docs/*.md (the convention and its runner in
tests/docsnippets.py), and the docs site's own checks."""

from __future__ import annotations

import importlib
import os
import pkgutil
import subprocess
import sys
import zlib
from pathlib import Path

import pytest

from tests.docsnippets import (
    ROOT,
    SnippetSyntaxError,
    page_name,
    parse_snippets,
    read_snippets,
    run_page,
    run_snippets,
)

DOCS = ROOT / "docs"
README_MAX_LINES = 150
API_PACKAGES = ("cell", "envs", "controllers")


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
