"""The ``musclecell`` command line: run episodes, export and render the scene, plan the cut,
diagnose measurements, import robot logs, benchmark, sweep, train and evaluate policies.

Each sub-package supplies its own commands (its ``command`` module); this package builds the
top parser from them and runs the chosen one, turning named errors and stop signals into exit
codes:

====  ==========================================================================
code  meaning
====  ==========================================================================
0     done
1     an error the command does not name (a bug): Python's traceback on stderr
2     bad input, or an output that cannot be written (nothing written); a malformed
      command line
3     the simulation diverged (nothing written)
4     a sweep or batch finished with failed rows (its table and summary written whole)
130   stopped by Ctrl-C (SIGINT); temporary files removed
143   stopped by SIGTERM (129: SIGHUP); temporary files removed
====  ==========================================================================
"""

from __future__ import annotations

import argparse
import os
import sys
from importlib.metadata import PackageNotFoundError, version

from cell.bench.command import add_bench
from cell.cli.signals import stop_signals_raise
from cell.diagnosis.command import add_diagnose
from cell.errors import DivergenceError, FailedRowsError, MusclecellError, Stopped
from cell.learning.command import add_learning
from cell.logs.command import add_log_diagnosis, add_replay
from cell.outputs import discard_pending
from cell.robotlog.command import add_import
from cell.scale.command import add_batch, add_log_cluster, add_sweep
from cell.sim.command import add_simulation
from cell.sim.examples import add_scenarios

#: Exit codes (module docstring).
EXIT_INPUT, EXIT_DIVERGED, EXIT_FAILED_ROWS, EXIT_INTERRUPTED = 2, 3, 4, 130


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``musclecell``."""
    parser = argparse.ArgumentParser(prog="musclecell",
                                     description=__doc__.split("\n\n")[0].replace("``", ""),
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="exit codes: 0 done, 1 an unnamed error (a bug; "
                                     "traceback), 2 bad input or output (nothing written),\n"
                                     "3 diverged, 4 a sweep or batch finished with failed rows, "
                                     "130/143/129 stopped by SIGINT/SIGTERM/SIGHUP (docs/cli.md)")
    parser.add_argument("--version", action="version", version=f"musclecell {_version()}")
    commands = parser.add_subparsers(dest="command", required=True)
    add_simulation(commands)
    add_replay(commands)
    add_scenarios(commands)
    add_log_cluster(add_log_diagnosis(commands))
    add_batch(add_diagnose(commands))
    add_import(commands)
    add_bench(commands)
    add_learning(commands)
    add_sweep(commands)
    return parser


def _version() -> str:
    """The installed package's version (a source tree that is not installed has none)."""
    try:
        return version("musclecell")
    except PackageNotFoundError:
        return "(not installed)"


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``musclecell`` console script; returns the exit code.

    It chooses headless rendering (``MUJOCO_GL=egl`` unless set) before any handler imports
    MuJoCo, which reads the variable at its own import, and sends MuJoCo's warnings to
    stderr only (no ``MUJOCO_LOG.TXT``) for the commands that simulate.
    """
    os.environ.setdefault("MUJOCO_GL", "egl")
    args = build_parser().parse_args(argv)
    if getattr(args, "uses_mujoco", True):
        from cell.sim.mujocolog import warnings_to_stderr

        warnings_to_stderr()
    try:
        with stop_signals_raise():
            try:
                return args.handler(args)
            finally:
                discard_pending()
    except DivergenceError as exc:
        print(f"musclecell: {exc}", file=sys.stderr)
        return EXIT_DIVERGED
    except FailedRowsError as exc:
        print(f"musclecell: {exc}", file=sys.stderr)
        return EXIT_FAILED_ROWS
    except MusclecellError as exc:
        print(f"musclecell: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except Stopped as exc:
        print(f"musclecell: stopped ({exc}); partial files removed", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("musclecell: interrupted; partial files removed", file=sys.stderr)
        return EXIT_INTERRUPTED
