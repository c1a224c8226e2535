"""The command-line side of sweeps and batches: ``musclecell sweep``, the ``--batch`` of
``musclecell diagnose``, and their ``--address`` and ``--workers``; the ``--address`` of
``musclecell diagnose-logs`` (its replays on a Ray cluster).

Light at import (the parser is built for every command): the handlers import the rest.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cell.errors import FailedRowsError, InputError
from cell.options import add_out, add_quiet
from cell.outputs import Output, check_outputs

if TYPE_CHECKING:
    from cell.scale.pool import RunPool, Workers

#: What a log diagnosis does without Ray (the end of the install hint).
LOGS_WITHOUT_RAY = "drop --address: the replays run on this machine's cores"


def add_sweep(commands: argparse._SubParsersAction) -> None:
    """The ``sweep`` subcommand."""
    sweep = commands.add_parser(
        "sweep", help="run every episode of a sweep file, one Ray task each (needs the scale "
        "extra unless --workers 1)")
    sweep.add_argument("sweep", type=Path, metavar="SWEEP",
                       help="sweep TOML file (its keys: docs/sweeps.md, A sweep file)")
    add_out(sweep, "results folder; runs already in it are skipped", required=True,
            folder=True)
    add_workers(sweep)
    sweep.add_argument("--retry-failed", action="store_true",
                       help="play again the runs in --out that failed or diverged")
    add_quiet(sweep)
    sweep.set_defaults(handler=sweep_command)


def add_batch(diagnosis: argparse.ArgumentParser) -> None:
    """``--batch``, ``--address`` and ``--workers`` on the ``diagnose`` parser (its ``--out``
    is then the results folder): with ``--batch`` the command diagnoses many sets, else the
    one-set handler it had runs."""
    one_set = diagnosis.get_default("handler")
    diagnosis.add_argument("--batch", type=Path, metavar="DIR",
                           help="diagnose every set in this folder, one Ray task each, into "
                           "one table in --out (needs the scale extra unless --workers 1)")
    add_workers(diagnosis, "; one set: processes fitting candidates side by side (default: "
                "one per core, or MUSCLECELL_WORKERS)")

    def handler(args: argparse.Namespace) -> int:
        return diagnose_batch_command(args) if args.batch is not None else one_set(args)

    diagnosis.set_defaults(handler=handler)


def add_log_cluster(logs: argparse.ArgumentParser) -> None:
    """``--address`` on the ``diagnose-logs`` parser: with it, the replays run on that Ray
    cluster (:func:`log_cluster`), else on this machine's cores as before."""
    here = logs.get_default("handler")
    logs.add_argument("--address",
                      help="Ray cluster to replay on: auto, HEAD_HOST:PORT or ray://HOST:PORT "
                      "(needs the scale extra; --workers is then the replays at a time, "
                      "default the whole cluster; default: processes on this machine)")

    def handler(args: argparse.Namespace) -> int:
        if args.address is None:
            return here(args)
        return here(args, cluster=log_cluster(args.workers, args.address))

    logs.set_defaults(handler=handler)


def log_cluster(workers: int | None, address: str) -> RunPool:
    """The pool, not yet entered, that plays a log diagnosis's replays on the Ray cluster at
    ``address``, ``workers`` at a time (None: as many as the cluster takes); checked first.

    Raises:
        PoolError: ``address`` is not a Ray address, ``workers`` is below one, or Ray is not
            installed (the install hint).
    """
    from cell.rayconnect import require_ray
    from cell.scale.pool import RunPool, Workers

    pool = RunPool(Workers(workers, address))
    require_ray("--address", LOGS_WITHOUT_RAY)
    return pool


def add_workers(command: argparse.ArgumentParser, note: str = "") -> None:
    """``--address`` and ``--workers`` of a command that plays many runs; ``note`` ends the
    help of ``--workers``."""
    command.add_argument("--address",
                         help="Ray cluster to run on: auto, HEAD_HOST:PORT or "
                         "ray://HOST:PORT (default: start Ray on this machine)")
    command.add_argument("--workers", type=int,
                         help="runs side by side (default: one per core, or the whole "
                         "cluster); 1 runs them one by one in this process, without Ray"
                         + note)


def workers(args: argparse.Namespace) -> Workers:
    """The ``--workers`` and ``--address`` of a command that plays many runs."""
    from cell.scale.pool import Workers

    if args.workers == 1 and args.address is not None:
        raise InputError(None, "--workers", "1 plays the runs here, without Ray: drop "
                         "--address, or give the cluster more workers")
    return Workers(args.workers, args.address)


def sweep_command(args: argparse.Namespace) -> int:
    """``musclecell sweep``; a run that failed fails the command once all are written
    (:func:`no_failed_rows`)."""
    from cell.scale.sweep import run_sweep

    pool = workers(args)
    check_outputs([Output(args.out, "--out", folder=True)], [args.sweep])
    outcome = run_sweep(args.sweep, args.out, pool,
                        retry_failed=args.retry_failed, progress=not args.quiet)
    statuses = [row["status"] for row in outcome.rows]
    print(f"{len(statuses)} runs ({outcome.played} played now, {outcome.skipped} found "
          f"finished in {args.out}): {statuses.count('ok')} finished, "
          f"{statuses.count('diverged')} diverged, {statuses.count('failed')} failed; "
          f"{outcome.wall_s:.1f} s; wrote {', '.join(p.name for p in outcome.files)}")
    return no_failed_rows(outcome.rows, args.out, "runs")


def diagnose_batch_command(args: argparse.Namespace) -> int:
    """``musclecell diagnose --batch``; a set that failed fails the command once all are
    written (:func:`no_failed_rows`)."""
    from cell.scale.batch import diagnose_batch

    extra = [name for name, value in (("set_dir", args.set_dir),
                                      ("--material", args.material),
                                      ("--report", args.report),
                                      ("--suggest", args.suggest or None)) if value is not None]
    if extra:
        raise InputError(None, extra[0],
                         "diagnose --batch PARENT takes --out DIR (and --address, --workers), "
                         "and writes each set's JSON and material there")
    pool = workers(args)
    check_outputs([Output(args.out, "--out", folder=True)], [args.batch])
    outcome = diagnose_batch(args.batch, args.out, pool, progress=not args.quiet)
    done = sum(row["status"] == "ok" for row in outcome.rows)
    print(f"{len(outcome.rows)} sets ({outcome.played} diagnosed now, {outcome.skipped} found "
          f"done in {args.out}): {done} diagnosed, {len(outcome.rows) - done} failed; "
          f"{outcome.wall_s:.1f} s; wrote {', '.join(p.name for p in outcome.files)}")
    return no_failed_rows(outcome.rows, args.out, "sets")


def no_failed_rows(rows: list[dict[str, Any]], out: Path, what: str) -> int:
    """0, the exit code of a sweep or batch (``what``: its rows' name) written to ``out``
    whose rows all ran; a diverged run is a result of the physics swept, not a failure.

    Raises:
        FailedRowsError: a row whose status is ``failed`` (exit 4; the folder is whole).
    """
    failed = sum(row["status"] == "failed" for row in rows)
    if failed:
        raise FailedRowsError(out, failed, len(rows), what)
    return 0
