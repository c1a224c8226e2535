"""The examples the package ships, so that an installed package has them, not only a checkout:
the scenarios, the sweep and the example script of ``scenarios/`` (``cell.scenarios``) and
the measured sets of ``assets/measured/``. ``musclecell scenarios`` lists them and
``musclecell scenarios copy NAME [DEST]`` copies one out. A scenario names the package's
data files as ``assets/...``, which resolve wherever the copy lies; a sweep names its scenario
relative to itself (``../default.toml``).

Example:
    >>> names = [example.name for example in examples()]
    >>> "default" in names, "quick" in names, "beef_round_example" in names
    (True, True, True)
"""

from __future__ import annotations

import argparse
import ast
import itertools
import re
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path

from cell.assets import asset_path
from cell.errors import InputError, OutputError
from cell.outputs import write_together

#: The folder of the shipped scenarios (``scenarios/`` in a checkout).
SCENARIOS = Path(str(files("cell.scenarios")))


@dataclass(frozen=True)
class Example:
    """One shipped example: ``name`` (what ``copy`` takes), ``kind`` (``scenario``,
    ``sweep``, ``script`` or ``measured set``), ``path`` (its file, or a set's folder) and
    ``summary`` (its first comment or docstring line).

    Example:
        >>> example_path("default").name
        'default.toml'
    """

    name: str
    kind: str
    path: Path
    summary: str


def examples() -> list[Example]:
    """Every shipped example: scenarios, sweeps, scripts, then measured sets, each by name."""
    found = [Example(path.stem, "scenario", path, _summary(path))
             for path in sorted(SCENARIOS.glob("*.toml"))]
    found += [Example(f"sweeps/{path.stem}", "sweep", path, _summary(path))
              for path in sorted(SCENARIOS.glob("sweeps/*.toml"))]
    found += [Example(path.stem, "script", path, _summary(path))
              for path in sorted(SCENARIOS.glob("*.py")) if path.name != "__init__.py"]
    found += [Example(path.name, "measured set", path, _summary(path / "specimen.toml"))
              for path in sorted(asset_path("measured").iterdir()) if path.is_dir()]
    return found


def example_path(name: str) -> Path:
    """The shipped file (or set's folder) of the example ``name`` (with or without its file's
    suffix).

    Raises:
        InputError: no example of that name (``field`` "NAME"), naming the known ones.
    """
    known = examples()
    for example in known:
        if name in (example.name, f"{example.name}{example.path.suffix}"):
            return example.path
    raise InputError(None, "NAME", f"no shipped example {name!r}; known: "
                     f"{', '.join(example.name for example in known)}")


def copy_example(name: str, destination: str | Path = ".") -> Path:
    """Copy the example ``name`` to ``destination``: into it under its own name where it is a
    folder, else to that path. Returns what was written; nothing is when it fails.

    Raises:
        InputError: an unknown example.
        OutputError: the target exists.

    Example:
        >>> import tempfile
        >>> copy_example("quick", tempfile.mkdtemp()).name
        'quick.toml'
    """
    source = example_path(name)
    target = Path(destination)
    if target.is_dir():
        target = target / source.name
    if target.exists():
        raise OutputError(target, "DEST", "exists: remove it or copy elsewhere")
    if source.is_dir():
        write_together({target / path.name: path.read_bytes()
                        for path in sorted(source.iterdir()) if path.is_file()})
    else:
        write_together({target: source.read_bytes()})
    return target


def _summary(path: Path) -> str:
    """The first clause of ``path``'s docstring (a script) or of its leading comment: up to
    a colon, a bracket or a full stop."""
    text = path.read_text()
    if path.suffix == ".py":
        lines = (ast.get_docstring(ast.parse(text)) or "").splitlines()
    else:
        lines = [line.lstrip("# ") for line in itertools.takewhile(
            lambda line: line.startswith("#"), text.splitlines())]
    words = " ".join(line.strip() for line in lines).replace("``", "")
    return re.split(r": | \(|\. ", words, maxsplit=1)[0].rstrip(".")


def add_scenarios(commands: argparse._SubParsersAction) -> None:
    """The ``scenarios`` subcommand: the list, and ``copy``."""
    parser = commands.add_parser(
        "scenarios", help="list the example scenarios, sweeps, script and measured sets the "
        "package ships; `copy NAME [DEST]` copies one out")
    actions = parser.add_subparsers(dest="action", help="copy: copy an example out (none: "
                                    "list them)")
    copy = actions.add_parser("copy", help="copy an example out (a measured set: its folder)")
    copy.add_argument("name", metavar="NAME", help="the example's name, as the list gives it")
    copy.add_argument("destination", metavar="DEST", nargs="?", default=".",
                      help="a folder to copy into (default: the current one), or the new "
                      "file's path")
    parser.set_defaults(handler=scenarios_command, uses_mujoco=False)


def scenarios_command(args: argparse.Namespace) -> int:
    """List the shipped examples, or copy one out."""
    if args.action == "copy":
        print(f"wrote {copy_example(args.name, args.destination)}")
        return 0
    width = max(len(example.name) for example in examples())
    for example in examples():
        print(f"{example.kind:<13} {example.name:<{width}}  {example.summary}")
    return 0
