"""The ``musclecell`` command line: run episodes, export the scene, benchmark."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

from cell.errors import DivergenceError, MusclecellError, ScenarioError


def _run(args: argparse.Namespace) -> int:
    from cell.episode import Episode
    from cell.io import write_json
    from cell.scenario import load_scenario

    scenario = load_scenario(args.scenario)
    if args.seed is not None:
        if args.seed < 0:
            raise ScenarioError(None, "--seed", f"must be >= 0, got {args.seed}")
        scenario = replace(scenario, seed=args.seed)
    summary = Episode(scenario).run(rerun_path=args.rerun, progress=not args.quiet)
    if args.summary:
        write_json(args.summary, summary)
    result = summary["result"]
    print(f"released {result['released_fraction']:.1%} of {result['bindings']} bindings "
          f"{result['released_by_rule']}, median gap {result['gap_m']['median'] * 1e3:.1f} mm, "
          f"knife tracking median {result['knife_tracking_error_m']['median'] * 1e3:.2f} mm, "
          f"real-time factor {summary['timing']['real_time_factor']:.3f}")
    return 0


def _export(args: argparse.Namespace) -> int:
    from cell.scenario import load_scenario
    from cell.scene import build_scene, export_mjcf

    path = export_mjcf(build_scene(load_scenario(args.scenario)), args.output)
    print(f"wrote {path}")
    return 0


def _bench(args: argparse.Namespace) -> int:
    from cell.bench import run_bench
    from cell.io import write_json

    report = run_bench(args.scenario, quick=args.quick)
    write_json(args.json, report)
    for name, entry in report["entries"].items():
        print(f"{name}: {entry['value']:.4g} {entry['unit']}")
    print(f"wrote {args.json}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``musclecell``."""
    parser = argparse.ArgumentParser(prog="musclecell", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)

    run = commands.add_parser("run", help="run a scripted cutting episode")
    run.add_argument("scenario", type=Path, help="scenario TOML file")
    run.add_argument("--rerun", type=Path, help="write a Rerun recording (.rrd) here")
    run.add_argument("--summary", type=Path, help="write the summary JSON here")
    run.add_argument("--seed", type=int, help="override the scenario's seed")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.set_defaults(handler=_run)

    export = commands.add_parser("export-mjcf", help="write the scene as MJCF")
    export.add_argument("scenario", type=Path)
    export.add_argument("output", type=Path)
    export.set_defaults(handler=_export)

    bench = commands.add_parser("bench", help="benchmark the cell, JSON out")
    bench.add_argument("--scenario", type=Path, default=Path("scenarios/default.toml"))
    bench.add_argument("--json", type=Path, default=Path("out/bench.json"))
    bench.add_argument("--quick", action="store_true",
                       help="fewer repetitions and a short episode (for smoke tests)")
    bench.set_defaults(handler=_bench)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``musclecell`` console script."""
    args = build_parser().parse_args(argv)
    try:
        return args.handler(args)
    except DivergenceError as exc:
        print(f"musclecell: {exc}", file=sys.stderr)
        return 3
    except MusclecellError as exc:
        print(f"musclecell: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
