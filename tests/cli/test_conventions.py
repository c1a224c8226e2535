"""The command line's conventions (docs/cli.md): every option documented on the page and
helped in ``--help``, ``--version``, one spelling of the main output with the old ones still
accepted (with a warning), the exit codes listed."""

from __future__ import annotations

import argparse
import re
from importlib.metadata import version
from pathlib import Path

import pytest

from cell.cli import __doc__ as CLI_DOC
from cell.cli import build_parser, main
from tests.docsnippets import ROOT

CLI_PAGE = (ROOT / "docs" / "cli.md").read_text(encoding="utf-8")


def _commands() -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in build_parser()._actions
                  if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def _arguments(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    return [a for a in parser._actions if not isinstance(a, argparse._HelpAction)]


def test_every_option_of_every_command_is_on_the_cli_page() -> None:
    missing = [f"{name} {option}" for name, parser in _commands().items()
               for action in _arguments(parser) for option in action.option_strings
               if not re.search(rf"(?<![\w-]){re.escape(option)}(?![\w-])", CLI_PAGE)]
    assert not missing, f"docs/cli.md does not name: {missing}"


def test_every_command_has_its_section_on_the_cli_page() -> None:
    for name in _commands():
        assert f"## musclecell {name}\n" in CLI_PAGE, name


def test_every_argument_of_every_command_has_help_text() -> None:
    helped = build_parser()._actions[-1]._choices_actions
    assert {a.dest for a in helped} == set(_commands())
    assert all(a.help for a in helped)
    unhelped = [f"{name} {action.option_strings or action.dest}"
                for name, parser in _commands().items() for action in _arguments(parser)
                if not action.help or action.help == argparse.SUPPRESS]
    assert not unhelped, unhelped


def test_version_is_the_installed_one(capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as end:
        main(["--version"])
    assert end.value.code == 0
    assert capsys.readouterr().out == f"musclecell {version('musclecell')}\n"


@pytest.mark.parametrize(("argv", "old"), [
    (["run", "s.toml", "--summary", "o.json"], "--summary"),
    (["plan", "s.toml", "--json", "o.json"], "--json"),
    (["render", "s.toml", "--png", "o.json"], "--png"),
    (["diagnose", "set", "--json", "o.json"], "--json"),
    (["bench", "--json", "o.json"], "--json"),
])
def test_an_old_spelling_of_the_output_still_works_with_a_warning(
        argv: list[str], old: str, capsys: pytest.CaptureFixture) -> None:
    assert build_parser().parse_args(argv).out == Path("o.json")
    warning = capsys.readouterr().err
    assert f"{old} is deprecated, use --out" in warning


def test_the_old_positional_output_of_export_mjcf_still_writes_it(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "cell.xml"
    assert main(["export-mjcf", str(ROOT / "scenarios" / "quick.toml"), str(out)]) == 0
    assert out.read_text().startswith("<mujoco")
    assert "the positional OUTPUT is deprecated, use --out" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["plan", "s.toml"], ["render", "s.toml"],
                                  ["diagnose", "set"], ["diagnose-logs", "a", "b"],
                                  ["learn", "Cut-v2", "--steps", "1"], ["sweep", "s.toml"]])
def test_a_required_output_is_shown_and_asked_for_by_the_parser(
        argv: list[str], capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as end:
        main(argv)
    assert end.value.code == 2
    error = capsys.readouterr().err
    assert "-o FILE" in error or "-o DIR" in error
    assert "the following arguments are required: -o/--out" in error


def test_the_training_benchmark_is_asked_for_by_name(capsys: pytest.CaptureFixture) -> None:
    assert main(["bench", "cell", "--learn", "--out", "unused.json"]) == 2
    assert "--learn" in capsys.readouterr().err
    assert build_parser().parse_args(["bench", "env"]).learn is False


@pytest.mark.parametrize("code", ["0", "1", "2", "3", "130", "143", "129"])
def test_every_exit_code_is_listed(code: str) -> None:
    assert re.search(rf"^\| (\d+, )?{code}(, \d+)? \|", CLI_PAGE, re.MULTILINE), code
    assert re.search(rf"(^|\D){code}(\D|$)", CLI_DOC), code
