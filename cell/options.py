"""The command line's shared options: the main output ``--out``/``-o`` (a file, or a folder
when the command writes several files), with the old spellings it replaces accepted for one
release with a warning on stderr, and ``--quiet``.

The parsers of every package's ``command`` module build these options here, so that every
command spells them one way.

Example:
    >>> import argparse
    >>> parser = argparse.ArgumentParser()
    >>> add_out(parser, "write the summary JSON here", old=("--summary",))
    >>> parser.parse_args(["-o", "s.json"]).out
    PosixPath('s.json')
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from cell.errors import InputError

#: What a deprecated spelling's warning promises.
REMOVAL = "it is accepted until the next release"


def warn_deprecated(old: str, new: str) -> None:
    """Tell the user on stderr that ``old`` is spelled ``new`` now."""
    print(f"musclecell: warning: {old} is deprecated, use {new}; {REMOVAL}", file=sys.stderr)


class _Spellings(argparse.Action):
    """Stores the option's value, as ``store`` does; given by one of its ``deprecated``
    spellings, it warns first (:func:`warn_deprecated`)."""

    def __init__(self, option_strings: Sequence[str], dest: str,
                 deprecated: Sequence[str] = (), **kwargs: Any) -> None:
        super().__init__(option_strings, dest, **kwargs)
        self.deprecated = tuple(deprecated)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        if option_string in self.deprecated:
            warn_deprecated(option_string, "--out")
        setattr(namespace, self.dest, values)


def add_out(parser: argparse.ArgumentParser, text: str, *, required: bool = False,
            folder: bool = False, old: Sequence[str] = ()) -> None:
    """The command's main output, ``-o``/``--out`` (``args.out``, a Path or None): a file, or
    with ``folder`` a folder; ``old``: the spellings it had, still accepted with a warning."""
    note = f" (old spelling {', '.join(old)}: deprecated)" if old else ""
    parser.add_argument("-o", "--out", *old, dest="out", type=Path, required=required,
                        metavar="DIR" if folder else "FILE", action=_Spellings,
                        deprecated=old, help=text + note)


def moved_positional(value: Path | None, out: Path | None, name: str) -> Path | None:
    """The output given as ``--out``, or by the positional ``name`` it replaces (with the
    warning); both at once is a usage error.

    Raises:
        InputError: both given.
    """
    if value is None:
        return out
    if out is not None:
        raise InputError(None, "--out", f"give the output once: --out, or the deprecated "
                         f"positional {name}, not both")
    warn_deprecated(f"the positional {name}", "--out")
    return value


def add_quiet(parser: argparse.ArgumentParser) -> None:
    """``-q``/``--quiet``: no progress bar on stderr (:mod:`cell.progress`)."""
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
