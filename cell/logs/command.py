"""``musclecell replay`` and ``diagnose-logs``: a separation log replayed in the simulation and
compared, and the diagnosis of a batch of them (docs/logs.md).

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
    from cell.logs.replays import ReplayPool


def add_replay(commands: argparse._SubParsersAction) -> None:
    """The ``replay`` subcommand."""
    replay = commands.add_parser(
        "replay", help="replay a separation log: the tools follow its poses, every channel "
        "compared per phase (docs/logs.md)")
    replay.add_argument("logs", type=Path, nargs="+", metavar="LOG",
                        help="the log's folder (log.toml, knife.csv, ...); several: one batch "
                        "of meat, which must share tools, sensors and material")
    add_out(replay, "write replay.json and the channels side by side (<channel>.csv) into "
            "this folder (several logs: a folder each in it, by the log folder's name)",
            folder=True)
    add_quiet(replay)
    replay.set_defaults(handler=replay_command)



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
                        "per core and at least one per log, or MUSCLECELL_WORKERS; with "
                        "--address, the whole cluster)")
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
    from cell.diagnosis.engine.determined import shown
    from cell.extras import require
    from cell.folders import write_folder
    from cell.logs.batch import read_log_batch
    from cell.logs.causes import CAUSES
    from cell.logs.diagnosis import LogDiagnosisParams, diagnose_logs
    from cell.logs.report import write_log_diagnosis

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
          progress_bar("replay", quiet=args.quiet, total=0) as bar):
        diagnosis = diagnose_logs(batch, params, pool, bar)
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


def replay_command(args: argparse.Namespace) -> int:
    """``musclecell replay``: the logs read (a bad one, or logs that are not one batch, stop
    it: nothing written), replayed and compared."""
    from cell.folders import write_folder
    from cell.logs.batch import read_log_batch
    from cell.logs.replay import replay, write_replay
    from cell.measure.logs import read_log

    check_outputs([args.out and Output(args.out, "--out", folder=True, whole=True,
                                      marks=("replay.json",))],
                  args.logs)
    logs = (read_log_batch(args.logs).logs if len(args.logs) > 1
            else (read_log(args.logs[0]),))
    names = [log.folder.name for log in logs]
    if len(set(names)) < len(names):
        names = [f"{k + 1}-{name}" for k, name in enumerate(names)]
    results = []
    for log in logs:
        results.append(replay(log, progress=not args.quiet))
        _print_replay(results[-1].summary())
    if args.out:
        # One folder for all the logs, written whole once every replay is done.
        write_folder(args.out, lambda folder: [
            write_replay(folder / name if len(logs) > 1 else folder, result)
            for name, result in zip(names, results, strict=True)])
    return 0


def _print_replay(summary: dict) -> None:
    print(f"{summary['log']}:")
    for name, phases in summary["rmse_share"].items():
        shares = ", ".join(f"{phase} {'-' if v is None else f'{v:.1%}'}"
                           for phase, v in phases.items())
        print(f"  {name}: RMSE over peak {shares}")
    counts = summary["counts"]
    print(f"  released {counts['released']['replayed']} (logged "
          f"{counts['released']['logged']}), torn {counts['torn']['replayed']} (logged "
          f"{counts['torn']['logged']}) of {summary['bindings']} bindings")
