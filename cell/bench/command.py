"""The command-line side of the benchmarks: ``musclecell bench [SUITE]``.

Light at import (the parser is built for every command): the handlers import the rest. Each
suite checks its outputs (:mod:`cell.outputs`) before it measures anything.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from cell.cores import default_workers
from cell.errors import InputError
from cell.options import add_out, add_quiet
from cell.outputs import Output, check_outputs
from cell.sim.examples import SCENARIOS

#: The scenario of the cell and perception suites when ``--scenario`` is not given: the
#: package's default scenario (``scenarios/default.toml`` of a checkout).
DEFAULT_SCENARIO = SCENARIOS / "default.toml"
#: Where each suite writes its JSON when ``--out`` is not given.
DEFAULT_JSON = {"cell": "out/bench.json", "tissue": "out/bench_tissue.json",
                "perception": "out/bench_perception.json", "env": "out/bench_env.json",
                "diagnose": "out/bench_diagnose.json", "sweep": "out/bench_sweep.json"}


def add_bench(commands: argparse._SubParsersAction) -> None:
    """The ``bench`` subcommand."""
    bench = commands.add_parser(
        "bench", help="benchmark a suite: the cell, the tissue models, the perception, the "
        "envs, the diagnosis or the sweeps")
    bench.add_argument("suite", nargs="?", choices=tuple(DEFAULT_JSON), default="cell",
                       help="cell: the whole cell (default); tissue: every tissue model on "
                       "the two muscles, with peers; perception: curvature, guideline and fit, "
                       "with peers; env: Gymnasium env steps per second; diagnose: the "
                       "diagnosis on unseen hidden-effect measurement sets; sweep: what Ray "
                       "costs per run, two workers against one")
    bench.add_argument("--scenario", type=Path, metavar="FILE",
                       help="scenario of the cell and perception suites (default: the "
                       "package's default scenario, `musclecell scenarios copy default`)")
    add_out(bench, "write the report JSON here (default out/bench.json, tissue: "
            "out/bench_tissue.json, perception: out/bench_perception.json, env: "
            "out/bench_env.json, diagnose: out/bench_diagnose.json, sweep: "
            "out/bench_sweep.json)", old=("--json",))
    bench.add_argument("--markdown", type=Path, metavar="FILE",
                       help="tissue suite: Markdown tables out; diagnose: the confusion table")
    bench.add_argument("--seeds", type=int,
                       help="diagnose suite: number of sets (default 10, --quick 3; with "
                       "--planes: per kind and cause, default 2, --quick 1)")
    bench.add_argument("--pairs", action="store_true",
                       help="diagnose suite: sets hiding two causes at once")
    bench.add_argument("--subtle", action="store_true",
                       help="diagnose suite: sets hiding one cause, half as strong")
    bench.add_argument("--triples", action="store_true",
                       help="diagnose suite: sets hiding three causes at once")
    bench.add_argument("--including", metavar="CAUSE",
                       help="diagnose suite, with --pairs or --triples: only those that hold "
                       "this cause (e.g. force_offset), on seeds of their own")
    bench.add_argument("--lab-protocol", action="store_true",
                       help="diagnose suite: sets as another generator draws them (slow "
                       "tension, relaxation and cyclic tests, noise 0.3-1.2 %% of the peak, "
                       "offsets 6-12 %%), on seeds of their own")
    bench.add_argument("--suggest", action="store_true",
                       help="diagnose suite: sets missing the tests that would show their "
                       "effect; the suggested next test against a random one")
    bench.add_argument("--spread", action="store_true",
                       help="diagnose suite: thirty-test sets of repeats, with a specimen "
                       "spread and without (--seeds pairs of sets)")
    bench.add_argument("--by-specimen", action="store_true",
                       help="diagnose suite, with --spread: sets that name their specimens "
                       "(five specimens running five ramps each, a modulus spread of 5-25 %%)")
    bench.add_argument("--planes", choices=("shear", "biaxial", "mixed", "all"),
                       help="diagnose suite: synthetic shear, biaxial or mixed sets (or all "
                       "three) hiding each cause they can show, a fibre turn beside "
                       "orthotropy or anisotropy, and none (--seeds sets of each)")
    bench.add_argument("--cut", action="store_true",
                       help="diagnose suite: hidden-effect cut sets, made by the full "
                       "simulation of a cut (with --pairs: two causes at once)")
    _add_log_options(bench)
    bench.add_argument("--workers", type=int,
                       help="diagnose suite: processes per diagnosis (default: one per core, or "
                       "MUSCLECELL_WORKERS; with --address, the whole cluster)")
    bench.add_argument("--address",
                       help="diagnose suite with --logs: replay on this Ray cluster; env "
                       "suite with --learn: also learn --address on one env per CPU of it "
                       "over one env here: auto, HEAD_HOST:PORT or ray://HOST:PORT (needs "
                       "the scale extra)")
    bench.add_argument("--learn", action="store_true",
                       help="env suite: also learn --envs 2 over --envs 1, two PPO runs "
                       "(needs the learn extra; minutes, eight with the full suite)")
    bench.add_argument("--shapes", type=int, default=0, help="perception: + N shape episodes")
    bench.add_argument("--shape-seed", type=int, default=5000,
                       help="perception with --shapes: the first shape's seed (default 5000)")
    bench.add_argument("--quick", action="store_true",
                       help="fewer repetitions and a short episode; tissue: the smallest "
                       "mesh only (for smoke tests)")
    add_quiet(bench)
    bench.set_defaults(handler=bench_command)


def _add_log_options(bench: argparse.ArgumentParser) -> None:
    """The options of the diagnose suite's log batches."""
    bench.add_argument("--logs", action="store_true",
                       help="diagnose suite: hidden-effect batches of separation logs, "
                       "diagnosed as diagnose-logs does (with --pairs: two causes at once)")
    bench.add_argument("--scenario-keys", action="store_true",
                       help="diagnose suite with --logs: the batches' worlds made by editing "
                       "the scenario keys each cause maps to (factors 0.4 to 2.5, drawn "
                       "shapes), as a user changes a world")
    bench.add_argument("--first-seed", type=int,
                       help="diagnose suite with --logs: the first batch's seed (default: the "
                       "kind's own, 70000 single, 71000 pairs, 72000 and 73000 with "
                       "--scenario-keys); fresh seeds for a bench the diagnosis has not seen")


def bench_command(args: argparse.Namespace) -> int:
    """``musclecell bench``: the options the suite takes checked, its outputs checked, then
    the suite."""
    suite = args.suite
    if suite not in ("tissue", "diagnose", "sweep"):
        for flag in ("seeds", "pairs", "subtle", "spread", "by_specimen", "triples",
                     "including", "suggest", "logs", "lab_protocol", "scenario_keys", "planes",
                     "first_seed"):
            if getattr(args, flag) not in (None, False):
                option = f"--{flag.replace('_', '-')}"
                raise InputError(None, option, f"only `musclecell bench diagnose` takes {option}")
        if args.markdown is not None:
            raise InputError(None, "--markdown",
                             "only `musclecell bench tissue` and `bench diagnose` write Markdown")
    if args.learn and suite != "env":
        raise InputError(None, "--learn", "only `musclecell bench env` takes --learn")
    if args.address is not None and not ((suite == "diagnose" and args.logs)
                                         or (suite == "env" and args.learn)):
        raise InputError(None, "--address", "only `musclecell bench diagnose --logs` and "
                         "`bench env --learn` take --address")
    if args.shapes < 0:
        raise InputError(None, "--shapes", f"must be >= 0, got {args.shapes}")
    json_path = args.out or Path(DEFAULT_JSON[suite])
    scenario = args.scenario
    if suite in ("cell", "perception"):
        scenario = args.scenario or DEFAULT_SCENARIO
        if not scenario.is_file():
            raise InputError(scenario, "--scenario", "no such scenario file")
    check_outputs([Output(json_path, "--out"),
                   args.markdown and Output(args.markdown, "--markdown")], [scenario])
    return _SUITES[suite](args, json_path, scenario)


def _progress(args: argparse.Namespace) -> Callable[[str], None]:
    """Where a suite's progress lines go: standard error, or nowhere with ``--quiet``."""
    if args.quiet:
        return lambda line: None
    return lambda line: print(line, file=sys.stderr, flush=True)


def _cell(args: argparse.Namespace, json_path: Path, scenario: Path) -> int:
    from cell.bench.cell import run_bench
    from cell.outputs import write_json

    report = run_bench(scenario, quick=args.quick, progress=_progress(args))
    write_json(json_path, report)
    _print_entries(report["entries"])
    print(f"wrote {json_path}")
    return 0


def _tissue(args: argparse.Namespace, json_path: Path, scenario: Path | None) -> int:
    from cell.bench.tissue import TissueBenchParams, markdown_report, run_tissue_bench
    from cell.outputs import write_atomic, write_json

    params = TissueBenchParams.quick() if args.quick else TissueBenchParams()
    report = run_tissue_bench(params, progress=_progress(args))
    write_json(json_path, report)
    print(f"wrote {json_path}")
    if args.markdown is not None:
        write_atomic(args.markdown, markdown_report(report))
        print(f"wrote {args.markdown}")
    for name, target in report["targets"].items():
        verdict = "not run" if target["pass"] is None else ("pass" if target["pass"] else "FAIL")
        print(f"{name}: {verdict}")
    return 0


def _perception(args: argparse.Namespace, json_path: Path, scenario: Path) -> int:
    from cell.bench.perception import run_perception_bench
    from cell.bench.shapes import shape_lines
    from cell.outputs import write_json

    report = run_perception_bench(scenario, quick=args.quick, shapes=args.shapes,
                                  shape_seed=args.shape_seed, progress=_progress(args))
    write_json(json_path, report)
    _print_entries(report["entries"])
    if "shapes" in report:
        print("\n".join(shape_lines(report["shapes"])))
    print(f"wrote {json_path}")
    return 0


def _print_entries(entries: dict) -> None:
    """One line per bench entry: value, peer and ratio, the per-step split, the target."""
    for name, entry in entries.items():
        line = f"{name}: {entry['value']:.4g} {entry['unit']}"
        if entry.get("ratio") is not None:
            line += f" (peer {entry['peer']:.4g}, ratio {entry['ratio']:.3g})"
        elif "skipped" in entry:
            line += f" (peer skipped: {entry['skipped']})"
        if "ms_per_step" in entry:
            split = entry["ms_per_step"]
            line += " (ms/step: " + ", ".join(f"{k} {v:.2f}" for k, v in split.items()) + ")"
        if "pass" in entry:
            line += f" target {entry['target']:.4g}: {'pass' if entry['pass'] else 'FAIL'}"
        print(line)


def _env(args: argparse.Namespace, json_path: Path, scenario: Path | None) -> int:
    from cell.bench.env import run_env_bench
    from cell.outputs import write_json

    if args.learn:
        from cell.extras import require

        require("stable_baselines3", "learn", "bench env --learn")
    report = run_env_bench(quick=args.quick, learn=args.learn, address=args.address,
                           progress=_progress(args))
    write_json(json_path, report)
    _print_entries(report["entries"])
    print(f"wrote {json_path}")
    return 0


def _sweep(args: argparse.Namespace, json_path: Path, scenario: Path | None) -> int:
    from cell.bench.sweep import run_sweep_bench
    from cell.outputs import write_json

    for name, value in (("--quick", args.quick), ("--seeds", args.seeds),
                        ("--markdown", args.markdown)):
        if value:
            raise InputError(None, name, "`musclecell bench sweep` runs the whole example "
                             "sweep and takes only --out")
    report = run_sweep_bench(progress=_progress(args))
    write_json(json_path, report)
    _print_entries(report["entries"])
    print(f"wrote {json_path}")
    return 0


def _diagnose_kind(args: argparse.Namespace) -> str:
    """The kind of diagnose bench the flags ask for, checked: one kind at most (the cut sets
    and the log batches with --pairs alone), --including with --pairs or --triples and a
    cause of the catalogue."""
    kinds = [flag for flag in ("pairs", "subtle", "triples", "suggest", "spread")
             if getattr(args, flag)]
    if len(kinds) > 1:
        raise InputError(None, f"--{kinds[1]}", f"give one of --{' --'.join(kinds)}, not both")
    if args.cut and args.logs:
        raise InputError(None, "--logs", "give one of --cut --logs, not both")
    if args.scenario_keys and not args.logs:
        raise InputError(None, "--scenario-keys", "goes with --logs")
    if args.first_seed is not None and not args.logs:
        raise InputError(None, "--first-seed", "goes with --logs")
    if args.first_seed is not None and args.first_seed < 100:
        raise InputError(None, "--first-seed", f"seeds below 100 are the tests', got "
                         f"{args.first_seed}")
    if args.by_specimen and not args.spread:
        raise InputError(None, "--by-specimen", "goes with --spread")
    if args.planes is not None and (kinds or args.cut or args.logs or args.lab_protocol):
        raise InputError(None, "--planes", "goes with --seeds, --workers and --quick alone")
    if args.lab_protocol and (args.cut or args.logs or args.suggest or args.spread):
        raise InputError(None, "--lab-protocol", "goes with the uniaxial sets alone")
    if (args.cut or args.logs) and kinds not in ([], ["pairs"]):
        what = "cut sets" if args.cut else "log batches"
        raise InputError(None, f"--{kinds[0]}", f"the {what} have single and --pairs kinds")
    if args.including is not None:
        from cell.diagnosis.specimen.causes import CAUSES

        if kinds not in (["pairs"], ["triples"]) or args.cut or args.logs:
            raise InputError(None, "--including", "goes with --pairs or --triples (uniaxial)")
        if args.including not in CAUSES:
            raise InputError(None, "--including",
                             f"must be a cause of {CAUSES}, got {args.including!r}")
    return kinds[0] if kinds and kinds[0] in ("pairs", "subtle", "triples") else "single"


def _diagnose(args: argparse.Namespace, json_path: Path, scenario: Path | None) -> int:
    from cell.bench.diagnose import bench_seeds, run_diagnose_bench
    from cell.outputs import write_atomic, write_json

    kind = _diagnose_kind(args)
    # A plane bench's count is per kind and cause (25 sets a seed over the three kinds).
    default = (1, 2) if args.planes is not None else (3, 10)
    count = args.seeds if args.seeds is not None else default[0 if args.quick else 1]
    if count < 1:
        raise InputError(None, "--seeds", f"must be >= 1, got {count}")
    workers = args.workers if args.workers is not None else default_workers()
    if args.suggest:
        from cell.bench import suggestbench

        report = suggestbench.run_suggest_bench(suggestbench.bench_seeds(count),
                                                workers=workers, progress=_progress(args))
    elif args.spread:
        from cell.bench import spread

        report = spread.run_spread_bench(spread.bench_seeds(count, args.by_specimen),
                                         workers=workers, progress=_progress(args),
                                         by_specimen=args.by_specimen)
    elif args.logs:
        report = _log_bench(args, kind, count)
    elif args.planes is not None:
        from cell.bench import planesets

        kinds = planesets.PLANE_KINDS if args.planes == "all" else (args.planes,)
        rows = planesets.plane_bench(planesets.bench_seeds(count), kinds, workers=workers,
                                     progress=_progress(args))
        report = planesets.plane_report(rows, kinds)
    elif args.cut:
        from cell.bench import diagnose_cuts

        report = diagnose_cuts.run_cut_diagnose_bench(diagnose_cuts.bench_seeds(count, kind),
                                                    kind, progress=_progress(args))
    else:
        protocol = "lab" if args.lab_protocol else "hidden"
        report = run_diagnose_bench(bench_seeds(count, kind, args.including, protocol),
                                    workers=workers, progress=_progress(args), kind=kind,
                                    including=args.including, protocol=protocol)
    write_json(json_path, report)
    print(report["markdown"], end="")
    for name, entry in report["entries"].items():
        print(f"{name}: {entry['value']:.4g} {entry['unit']}")
    for name, target in report["targets"].items():
        print(f"{name}: {target['value']:.4g} target {target['target']:.4g}: "
              f"{'pass' if target['pass'] else 'FAIL'}")
    print(f"wrote {json_path}")
    if args.markdown is not None:
        write_atomic(args.markdown, report["markdown"])
        print(f"wrote {args.markdown}")
    return 0


def _log_bench(args: argparse.Namespace, kind: str, count: int) -> dict[str, Any]:
    """The log batches' bench, its replays here (``--workers`` processes) or, with
    ``--address``, on that Ray cluster (joined once, before the first batch is drawn)."""
    from contextlib import nullcontext

    from cell.bench import diagnose_logs
    from cell.scale.command import log_cluster
    from cell.synthetic.logs import LOG_COUNT

    if args.scenario_keys:
        kind = "key-pairs" if kind == "pairs" else "keys"
    cluster = None if args.address is None else log_cluster(args.workers, args.address)
    # A cluster's: None, all of it; here at least one a log (cell.cores.default_workers).
    asked = args.workers if cluster is not None else args.workers or default_workers(LOG_COUNT)
    params = (diagnose_logs.LogBenchParams.quick(asked) if args.quick
              else diagnose_logs.LogBenchParams(workers=asked))
    with cluster or nullcontext() as pool:
        return diagnose_logs.run_log_diagnose_bench(
            diagnose_logs.bench_seeds(count, kind, args.first_seed), kind, params,
            progress=_progress(args), cluster=pool, replay_bar=not args.quiet)


_SUITES: dict[str, Callable[[argparse.Namespace, Path, Path | None], int]] = {
    "cell": _cell, "tissue": _tissue, "perception": _perception, "env": _env,
    "diagnose": _diagnose, "sweep": _sweep}
