"""``musclecell import``: robot logs of cuts into a measurement set (docs/robot-logs.md).

Light at import (no MuJoCo, no ROS reader): the handler imports the rest.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from cell.outputs import Output, check_outputs


def add_import(commands: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """The ``import`` subcommand; returns its parser."""
    parser = commands.add_parser(
        "import", help="turn robot logs of cuts (rostopic dumps, ROS 1/2 bags, MCAP) into a "
        "cut-test set, one test per log, as a mapping file says")
    parser.add_argument("mapping", type=Path,
                        help="the mapping file (TOML): topics, frames, block and blade")
    parser.add_argument("logs", type=Path, nargs="+",
                        help="one log per cut: a folder of rostopic echo -p dumps, a ROS 2 "
                        "bag's folder, a .bag or a .mcap file")
    parser.add_argument("--out", "-o", type=Path, required=True,
                        help="the set's folder to write (specimen.toml and tests.csv)")
    parser.set_defaults(handler=import_command, uses_mujoco=False)
    return parser


def import_command(args: argparse.Namespace) -> int:
    """``musclecell import MAPPING LOG... --out SET``: the output checked, the mapping read,
    every log converted, then the set written whole."""
    from cell.measure.specimens import SPECIMEN_FILE, TESTS_FILE
    from cell.robotlog.cutlog import import_cut_set
    from cell.robotlog.mapping import read_mapping

    check_outputs([Output(args.out, "--out", folder=True, whole=True,
                          marks=(SPECIMEN_FILE, TESTS_FILE))], [args.mapping, *args.logs])
    mapping = read_mapping(args.mapping)
    folder = import_cut_set(mapping, args.logs, args.out)
    print(f"musclecell import: {len(args.logs)} cut tests written to {folder}",
          file=sys.stderr)
    return 0
