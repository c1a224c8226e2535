"""``musclecell diagnose-logs``: the diagnosis of a batch of separation logs (docs/logs.md).

Light at import (the parser is built for every command): the handler imports the rest and
checks its outputs and the logs before any replay.
"""

from __future__ import annotations

import argparse
from contextlib import AbstractContextManager, nullcontext
from pathlib import Path
from typing import TYPE_CHECKING

from cell.errors import LogError
from cell.options import add_out, add_quiet
from cell.outputs import Output, check_outputs

if TYPE_CHECKING:
    from cell.sim.logreplays import ReplayPool


def add_log_diagnosis(commands: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """The ``diagnose-logs`` subcommand (its parser: :mod:`cell.scale` adds ``--address``)."""
    parser = commands.add_parser(
        "diagnose-logs", help="diagnose a batch of separation logs of one batch of meat: "
        "what the simulation gets wrong about them, why, and the extended world "
        "(docs/logs.md)")
    parser.add_argument("logs", type=Path, nargs="+", metavar="LOG",
                        help="the logs' folders (at least two; they share tools, sensors "
                        "and material)")
    add_out(parser, "write diagnosis.json, extended-material.toml, extended-scenario.toml "
            "and report.md (with plots) into this folder", required=True, folder=True)
    parser.add_argument("--workers", type=int, help="replays side by side (default: one "
                        "per core; with --address, the whole cluster)")
    parser.add_argument("--causes", nargs="+", metavar="CAUSE",
                        help="screen only these world causes (default: every one that "
                        "applies)")
    parser.add_argument("--no-plots", action="store_true",
                        help="no channels-<log>.png (they need the report extra)")
    add_quiet(parser)
    parser.set_defaults(handler=diagnose_logs_command)
    return parser


def diagnose_logs_command(args: argparse.Namespace,
                          cluster: AbstractContextManager[ReplayPool] | None = None) -> int:
    """Read the batch (a bad log stops it: nothing written), diagnose it, write it; the
    replays on this machine's processes, or on ``cluster`` (a pool entered only once the
    options and the logs are checked)."""
    from cell.determined import shown
    from cell.extras import require
    from cell.folders import write_folder
    from cell.sim.logbatch import read_log_batch
    from cell.sim.logcauses import CAUSES
    from cell.sim.logdiagnosis import LogDiagnosisParams, diagnose_logs
    from cell.sim.logreport import write_log_diagnosis

    check_outputs([Output(args.out, "--out", folder=True, whole=True,
                          marks=("diagnosis.json",))], args.logs)
    if args.workers is not None and args.workers < 1:
        raise LogError(None, "--workers", f"must be >= 1, got {args.workers}")
    unknown = sorted(set(args.causes or ()) - set(CAUSES))
    if unknown:
        raise LogError(None, "--causes", f"unknown cause {unknown[0]!r}; known: {list(CAUSES)}")
    if not args.no_plots:
        require("matplotlib", "report", "the log diagnosis's plots (or --no-plots)")
    batch = read_log_batch(args.logs)
    params = LogDiagnosisParams(workers=args.workers,
                                causes=tuple(args.causes) if args.causes else None)
    from cell.progress import progress_bar

    with (cluster or nullcontext() as pool,
          progress_bar("replay", quiet=args.quiet, desc="diagnose-logs") as bar):
        diagnosis = diagnose_logs(batch, params, pool, bar.update)
    write_folder(args.out, lambda folder: write_log_diagnosis(folder, batch, diagnosis,
                                                              plots=not args.no_plots))
    data = diagnosis.to_json()
    print(f"causes: {', '.join(data['causes']) or 'none'}; held-out force RMSE "
          f"{shown(data['baseline']['heldout_rmse_N'], '.3f')} N -> "
          f"{shown(data['extended']['heldout_rmse_N'], '.3f')} N "
          f"(gain {shown(data['gain'], '.2f')}); "
          f"{data['timing']['replays']} replays in {data['timing']['total_s']:.0f} s; "
          f"wrote {args.out}")
    return 0
