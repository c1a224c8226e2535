"""The format pages are the project's own: no page or module sends a user to a spec outside
the repository, and the log format page names everything the log reader requires."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from cell.measure import logs as logformat

ROOT = Path(__file__).resolve().parent.parent
LIBRARY = ("cell", "envs", "controllers", "scripts")
#: How the first sketch of the formats, outside the repository, used to be named.
OUTSIDE_SPEC = re.compile(r"shared spec|cell-logs|spec/|\.\./shared|the spec's "
                          r"(cut|plain|contract|sign|tables|cell)|: the spec\)",
                          re.IGNORECASE)


def _texts() -> list[Path]:
    files = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    for package in LIBRARY:
        files += sorted((ROOT / package).rglob("*.py"))
    return files


def _mentions(text: str) -> list[str]:
    return [match.group(0) for match in OUTSIDE_SPEC.finditer(text)]


def test_no_page_or_module_refers_to_an_outside_spec() -> None:
    found = {str(path.relative_to(ROOT)): hits for path in _texts()
             if (hits := _mentions(path.read_text(encoding="utf-8")))}
    assert not found, f"references to a spec outside the repository: {found}"


@pytest.mark.parametrize("text", ["the format of the shared spec `cell-logs.md`",
                                  "the contract of ``spec/measured-data.md``",
                                  "as the spec's cut table has it"])
def test_the_check_catches_the_old_references(text: str) -> None:
    assert _mentions(text)


def test_mujocos_spec_objects_are_no_outside_spec() -> None:
    assert not _mentions("Build ``arm`` as a spec whose base frame is the spec's world frame.")


def test_the_log_format_page_names_every_channel_and_column_the_reader_knows() -> None:
    page = (ROOT / "docs" / "log-format.md").read_text(encoding="utf-8")
    names = ["time_s", "grasp", *logformat.POSE, *logformat.FORCE, *logformat.TORQUE,
             *(f"{stem}.csv" for stem in logformat.CHANNELS), "log.toml"]
    missing = [name for name in names if f"`{name}`" not in page and f"{name} " not in page]
    assert not missing, f"docs/log-format.md does not name {missing}"


def test_the_log_format_page_names_every_table_the_reader_accepts() -> None:
    page = (ROOT / "docs" / "log-format.md").read_text(encoding="utf-8")
    for table in ("log", "sensors", "phases", "outcome"):
        assert f"`[{table}]`" in page
    for key in ("name", "scenario", "seed", "cut_s", "bindings", "released", "torn",
                "_rate_hz", "_tare_s"):
        assert f"`{key}`" in page or f"`<channel>{key}`" in page, key
