"""``musclecell import``: robot logs of cuts into a measurement set, or a whole cell's robot
log into a separation log, as the mapping file says (docs/robot-logs.md).

Light at import (no MuJoCo, no ROS reader): the handler imports the rest.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from cell.options import add_out
from cell.outputs import Output, check_outputs


def add_import(commands: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """The ``import`` subcommand; returns its parser."""
    parser = commands.add_parser(
        "import", help="turn robot logs (rostopic dumps, ROS 1/2 bags, MCAP) into a cut-test "
        "set, one test per log, or a whole cell's log into a separation log, as a mapping "
        "file says")
    parser.add_argument("mapping", type=Path, metavar="MAPPING",
                        help="the mapping file (TOML): a cut's topics, frames, block and blade; "
                        "or, with [channels], a whole cell's sensors")
    parser.add_argument("logs", type=Path, nargs="+", metavar="LOG",
                        help="one log per cut or per episode: a folder of rostopic echo -p "
                        "dumps, a ROS 2 bag's folder, a .bag or a .mcap file")
    add_out(parser, "the folder to write: the set (specimen.toml and tests.csv), or the "
            "separation log (several logs: a folder each in it)", required=True, folder=True)
    parser.set_defaults(handler=import_command, uses_mujoco=False)
    return parser


def import_command(args: argparse.Namespace) -> int:
    """``musclecell import MAPPING LOG... --out FOLDER``: the output checked, the mapping
    read, every log converted, then the set or the logs written whole."""
    from cell.config import read_toml
    from cell.errors import MappingError
    from cell.measure.specimens import SPECIMEN_FILE, TESTS_FILE
    from cell.robotlog.cellmapping import cell_mapping_from_toml, is_cell_mapping

    raw = read_toml(args.mapping, MappingError)
    whole_cell = is_cell_mapping(raw)
    marks = ("log.toml",) if whole_cell and len(args.logs) == 1 else (
        () if whole_cell else (SPECIMEN_FILE, TESTS_FILE))
    check_outputs([Output(args.out, "--out", folder=True, whole=True, marks=marks)],
                  [args.mapping, *args.logs])
    if whole_cell:
        from cell.robotlog.celllog import import_cell_logs

        folder = import_cell_logs(cell_mapping_from_toml(raw, args.mapping), args.logs,
                                  args.out)
        print(f"musclecell import: {len(args.logs)} separation log"
              f"{'s' if len(args.logs) > 1 else ''} written to {folder}", file=sys.stderr)
        return 0
    from cell.robotlog.cutlog import import_cut_set
    from cell.robotlog.mapping import mapping_from_toml

    folder = import_cut_set(mapping_from_toml(raw, args.mapping), args.logs, args.out)
    print(f"musclecell import: {len(args.logs)} cut tests written to {folder}",
          file=sys.stderr)
    return 0
