"""The ``musclecell`` command line: run episodes, export the scene, benchmark, train and
evaluate policies."""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from cell.errors import (
    DivergenceError,
    InputError,
    LearningError,
    MusclecellError,
    ScenarioError,
)
from cell.scale.command import add_sweep, add_workers

if TYPE_CHECKING:
    from cell.sim.scenario import Scenario


def _load(args: argparse.Namespace) -> Scenario:
    """The scenario named on the command line, with ``--seed`` applied."""
    from cell.sim.scenario import load_scenario

    scenario = load_scenario(args.scenario)
    if args.seed is not None:
        if args.seed < 0:
            raise ScenarioError(None, "--seed", f"must be >= 0, got {args.seed}")
        scenario = replace(scenario, seed=args.seed)
    return scenario


def _run(args: argparse.Namespace) -> int:
    from cell.io import write_json
    from cell.sim.episode import Episode

    scenario = _load(args)
    summary = Episode(scenario).run(rerun_path=args.rerun, progress=not args.quiet)
    if args.summary:
        write_json(args.summary, summary)
    result = summary["result"]
    print(f"released {result['released_fraction']:.1%} of {result['bindings']} bindings "
          f"{result['released_by_rule']}, median gap {result['gap_m']['median'] * 1e3:.1f} mm, "
          f"knife tracking median {result['knife_tracking_error_m']['median'] * 1e3:.2f} mm, "
          f"real-time factor {summary['timing']['real_time_factor']:.3f}")
    return 0


def _plan(args: argparse.Namespace) -> int:
    import numpy as np

    from cell.io import write_json
    from cell.robots.camera import CameraRig
    from cell.robots.names import CAMERA, KNIFE_TIP
    from cell.sim.episode import Episode
    from controllers.knife import plan_cut

    scenario = _load(args)
    episode = Episode(scenario)
    truth = episode.scene.mesh
    with CameraRig(episode.scene.model, CAMERA, scenario.camera.width_px,
                   scenario.camera.height_px) as rig:
        plan = episode.perceive(rig)  # what the episode would see with this seed
    tip_m, tip_rotation = episode.ik.site_pose(KNIFE_TIP)
    _, tip_path, window_s = plan_cut(
        plan.guideline.points_m, scenario.cut, scenario.layout.table_height_m,
        scenario.cut.start_s, tip_m, tip_rotation, interface_y=plan.interface_y)
    # How far the planned blade tip is from the true interface: what the cut would part.
    offset = np.abs(tip_path[:, 1] - truth.interface_y(tip_path[:, 0], tip_path[:, 2]))
    summary = {"scenario": scenario.name, "seed": scenario.seed, **plan.summary(),
               "knife": {"cut_window_s": list(window_s), "tip_points": len(tip_path),
                         "tip_offset_from_true_interface_m": {"mean": float(offset.mean()),
                                                              "max": float(offset.max())}}}
    write_json(args.json, summary)
    distance = plan.guideline_distance_m
    depth = plan.cut_depth_m
    print(f"guideline {plan.guideline.length_m:.3f} m, {len(plan.guideline.nodes)} nodes, "
          f"{distance.mean_m * 1e3:.1f} mm mean / {distance.max_m * 1e3:.1f} mm max from the "
          f"true top line; fit rms {plan.fit.rms_m * 1e3:.2f} mm; cut depth "
          f"{depth.min() * 1e3:.0f}-{depth.max() * 1e3:.0f} mm; knife tip "
          f"{offset.mean() * 1e3:.1f} mm mean from the true interface; perception "
          f"{plan.timings_s['total']:.2f} s; wrote {args.json}")
    return 0


def _export(args: argparse.Namespace) -> int:
    from cell.sim.assembly import build_scene, export_mjcf
    from cell.sim.scenario import load_scenario

    path = export_mjcf(build_scene(load_scenario(args.scenario)), args.output)
    print(f"wrote {path}")
    return 0


def _diagnose(args: argparse.Namespace) -> int:
    from cell.io import write_atomic, write_json
    from cell.rheology.diagnosis import DiagnosisParams, diagnose
    from cell.rheology.measured import load_measurement_set
    from cell.tissue.materialfile import material_to_toml

    if args.batch is not None:
        from cell.scale.command import diagnose_batch_command

        return diagnose_batch_command(args)
    if args.set_dir is None or args.json is None:
        raise InputError(None, "set_dir" if args.set_dir is None else "--json",
                         "missing: diagnose SET_DIR --json FILE, or --batch PARENT --out DIR")
    if args.address is not None:
        raise InputError(None, "--address", "only --batch runs on Ray")
    workers = (os.cpu_count() or 1) if args.workers is None else args.workers
    if workers < 1:
        raise InputError(None, "--workers", f"must be >= 1, got {workers}")
    material_path = args.material or args.json.with_name(f"{args.json.stem}-material.toml")
    if args.report is not None:
        from cell.extras import require

        require("matplotlib", "report", "the diagnosis report")
    measurements = load_measurement_set(args.set_dir)  # reads everything before any write
    result = diagnose(measurements, DiagnosisParams(workers=workers))
    extended = result.extended
    if args.report is not None:
        from cell.rheology.report import write_report

        write_report(result, args.report, material_path)
    write_atomic(material_path, material_to_toml(extended.material, result.material_comment()))
    write_json(args.json, result.to_json())
    print(f"causes: {', '.join(result.causes) or 'none (the baseline explains the data)'}; "
          f"held-out RMSE {result.baseline.heldout_rmse_n:.4g} N -> "
          f"{extended.heldout_rmse_n:.4g} N (gain {result.gain:.3f}, noise "
          f"{result.noise_n:.3g} N); wrote {args.json}, {material_path}"
          + (f", {args.report}" if args.report is not None else ""))
    return 0


def _bench(args: argparse.Namespace) -> int:
    from cell.bench.cell import run_bench
    from cell.io import write_json

    if args.suite == "tissue":
        return _bench_tissue(args)
    if args.suite == "diagnose":
        return _bench_diagnose(args)
    if args.suite == "sweep":
        return _bench_sweep(args)
    for flag in ("seeds", "pairs", "subtle"):
        if getattr(args, flag) not in (None, False):
            raise InputError(None, f"--{flag}", f"only `musclecell bench diagnose` takes --{flag}")
    if args.markdown is not None:
        raise InputError(None, "--markdown",
                         "only `musclecell bench tissue` and `bench diagnose` write Markdown")
    if args.suite == "perception":
        return _bench_perception(args)
    if args.suite == "env":
        return _bench_env(args)
    json_path = args.json or Path("out/bench.json")
    report = run_bench(args.scenario, quick=args.quick)
    write_json(json_path, report)
    for name, entry in report["entries"].items():
        print(f"{name}: {entry['value']:.4g} {entry['unit']}")
    print(f"wrote {json_path}")
    return 0


def _bench_tissue(args: argparse.Namespace) -> int:
    from cell.bench.tissue import TissueBenchParams, markdown_report, run_tissue_bench
    from cell.io import write_atomic, write_json

    params = TissueBenchParams.quick() if args.quick else TissueBenchParams()
    report = run_tissue_bench(params, progress=print)
    json_path = args.json or Path("out/bench_tissue.json")
    write_json(json_path, report)
    print(f"wrote {json_path}")
    if args.markdown is not None:
        write_atomic(args.markdown, markdown_report(report))
        print(f"wrote {args.markdown}")
    for name, target in report["targets"].items():
        verdict = "not run" if target["pass"] is None else ("pass" if target["pass"] else "FAIL")
        print(f"{name}: {verdict}")
    return 0


def _bench_perception(args: argparse.Namespace) -> int:
    from cell.bench.perception import run_perception_bench
    from cell.bench.shapes import shape_lines
    from cell.io import write_json

    report = run_perception_bench(args.scenario, quick=args.quick, shapes=args.shapes,
                                  shape_seed=args.shape_seed)
    json_path = args.json or Path("out/bench_perception.json")
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


def _bench_env(args: argparse.Namespace) -> int:
    from cell.bench.env import run_env_bench
    from cell.io import write_json

    report = run_env_bench(quick=args.quick)
    json_path = args.json or Path("out/bench_env.json")
    write_json(json_path, report)
    _print_entries(report["entries"])
    print(f"wrote {json_path}")
    return 0


def _bench_sweep(args: argparse.Namespace) -> int:
    from cell.bench.sweep import run_sweep_bench
    from cell.io import write_json

    for name, value in (("--quick", args.quick), ("--seeds", args.seeds),
                        ("--markdown", args.markdown)):
        if value:
            raise InputError(None, name, "`musclecell bench sweep` runs the whole example "
                             "sweep and takes only --json")
    report = run_sweep_bench()
    json_path = args.json or Path("out/bench_sweep.json")
    write_json(json_path, report)
    _print_entries(report["entries"])
    print(f"wrote {json_path}")
    return 0


def _bench_diagnose(args: argparse.Namespace) -> int:
    from cell.bench.diagnose import bench_seeds, run_diagnose_bench
    from cell.io import write_atomic, write_json

    kind = "pairs" if args.pairs else "subtle" if args.subtle else "single"
    if args.pairs and args.subtle:
        raise InputError(None, "--pairs", "give --pairs or --subtle, not both")
    count = args.seeds if args.seeds is not None else (3 if args.quick else 10)
    if count < 1:
        raise InputError(None, "--seeds", f"must be >= 1, got {count}")
    report = run_diagnose_bench(bench_seeds(count, kind), workers=args.workers,
                                progress=print, kind=kind)
    json_path = args.json or Path("out/bench_diagnose.json")
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


def _require_learn_extra() -> None:
    """Stable-Baselines3 (and torch) are the ``learn`` extra, not a dependency."""
    import importlib.util

    if importlib.util.find_spec("stable_baselines3") is None:
        raise LearningError(None, None, "training and evaluation need the learn extra: "
                            "pip install -e '.[learn]' (see README)")


def _learn(args: argparse.Namespace) -> int:
    _require_learn_extra()
    from cell.learning import ppo
    from cell.learning.environments import resolve_env_id
    from cell.learning.hyper import LearnSettings, PPOHyper, WarmStart, parse_json_object

    env_id = resolve_env_id(args.env)
    envs = args.envs if args.envs is not None else os.cpu_count() or 1
    if args.resume:
        if args.env_kwargs is not None or args.hyper is not None or args.warm_start:
            raise LearningError(None, "--resume", "continues the run as it was set: drop "
                                "--env-kwargs, --hyper and --warm-start")
        result = ppo.resume(args.out, env_id, args.steps, envs, args.minutes,
                            args.checkpoint_every)
    else:
        if args.warm_start_anchor and not args.warm_start:
            raise LearningError(None, "--warm-start-anchor", "needs --warm-start")
        warm = (WarmStart(args.warm_start, episodes=args.warm_start_episodes,
                          anchor_epochs=args.warm_start_anchor) if args.warm_start else None)
        settings = LearnSettings(env_id, parse_json_object(args.env_kwargs, "--env-kwargs"),
                                 args.seed, envs, args.steps, args.minutes,
                                 args.checkpoint_every, warm)
        hyper = PPOHyper().with_overrides(parse_json_object(args.hyper, "--hyper"))
        result = ppo.learn(settings, hyper, args.out)
    print(f"trained {result.steps} env steps in {result.wall_s:.1f} s (stopped by "
          f"{result.stopped_by}); wrote {result.out}")
    return 0


def _evaluate(args: argparse.Namespace) -> int:
    _require_learn_extra()
    from cell.learning.baselines import policy_folder
    from cell.learning.environments import resolve_env_id
    from cell.learning.evaluate import (
        EvaluationSettings,
        evaluate,
        parse_constant_actions,
        report_markdown,
        write_report,
    )
    from cell.learning.hyper import parse_json_object

    settings = EvaluationSettings(
        args.episodes, args.seed_start, args.workers or os.cpu_count() or 1,
        args.constant_search_seeds, parse_constant_actions(args.constant_actions))
    out = args.out or policy_folder(args.policy) / "evaluation"
    report = evaluate(args.policy, resolve_env_id(args.env),
                      parse_json_object(args.env_kwargs, "--env-kwargs"), settings)
    json_path = args.json or out / "evaluation.json"
    markdown_path = args.markdown or out / "evaluation.md"
    write_report(report, json_path, markdown_path, out / "episodes.csv")
    print(report_markdown(report), end="")
    print(f"wrote {json_path}, {markdown_path} and {out / 'episodes.csv'}")
    return 0


def _add_learning(commands: argparse._SubParsersAction) -> None:
    """The ``learn`` and ``evaluate`` subcommands."""
    from cell.learning.hyper import EVAL_SEED_START, TUNING_SEED_START

    learn = commands.add_parser(
        "learn", help="train a PPO policy on an env (needs the learn extra)")
    learn.add_argument("env", help="Gymnasium id, e.g. musclecell/Cut-v0 (or Cut-v0)")
    learn.add_argument("--algo", choices=("ppo",), default="ppo", help="algorithm (ppo)")
    learn.add_argument("--steps", type=int, required=True,
                       help="env steps of the whole run, those before a --resume included")
    learn.add_argument("--out", type=Path, required=True, help="folder of the run")
    learn.add_argument("--seed", type=int, default=0,
                       help=f"env i starts at seed SEED + i (training seeds < "
                       f"{EVAL_SEED_START}); default 0")
    learn.add_argument("--envs", type=int, help="envs side by side (default: one per core)")
    learn.add_argument("--minutes", type=float, help="stop after this wall time, min")
    learn.add_argument("--checkpoint-every", type=int, default=50_000,
                       help="env steps between checkpoints (default 50000)")
    learn.add_argument("--resume", action="store_true",
                       help="continue the run in --out from its latest checkpoint")
    learn.add_argument("--env-kwargs", help='JSON keyword arguments of the env, e.g. '
                       '\'{"time_limit_s": 3.0}\'')
    learn.add_argument("--hyper", help='JSON overrides of the PPO hyper-parameters, e.g. '
                       '\'{"n_steps": 512}\'')
    learn.add_argument("--warm-start", metavar="DEMONSTRATOR", help="clone this policy of "
                       "the observation before PPO: table-skimming-knife (Cut-v0), "
                       "hold-then-pull-away (Pull-v0)")
    learn.add_argument("--warm-start-episodes", type=int, default=24,
                       help="the demonstrator's episodes to clone (default 24)")
    learn.add_argument("--warm-start-anchor", type=int, default=0, metavar="EPOCHS",
                       help="after each PPO update, passes of the cloning loss over its "
                       "rollout, holding PPO near the demonstrator (default 0: none)")
    learn.set_defaults(handler=_learn)

    evaluation = commands.add_parser(
        "evaluate", help="evaluate a learned policy beside the random, best constant and "
        "scripted policies on the same seeds")
    evaluation.add_argument("policy", type=Path,
                            help="learn output folder, or its policy.zip")
    evaluation.add_argument("env", help="Gymnasium id, e.g. musclecell/Cut-v0")
    evaluation.add_argument("--episodes", type=int, default=50, help="per policy (default 50)")
    evaluation.add_argument("--seed-start", type=int, default=EVAL_SEED_START,
                            help=f"first evaluation seed (default {EVAL_SEED_START})")
    evaluation.add_argument("--out", type=Path,
                            help="folder of evaluation.json, evaluation.md and episodes.csv "
                            "(default: POLICY's folder/evaluation)")
    evaluation.add_argument("--json", type=Path, help="the report JSON here instead")
    evaluation.add_argument("--markdown", type=Path, help="the Markdown table here instead")
    evaluation.add_argument("--workers", type=int, help="processes (default: one per core)")
    evaluation.add_argument("--env-kwargs", help="JSON keyword arguments of the env")
    evaluation.add_argument("--constant-search-seeds", type=int, default=10,
                            help=f"tuning episodes per constant action, seeds "
                            f"{TUNING_SEED_START} on (default 10)")
    evaluation.add_argument("--constant-actions",
                            help="JSON list of the constant actions to choose from (default: "
                            "zero and each axis alone at +-0.5 and +-1)")
    evaluation.set_defaults(handler=_evaluate)


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

    plan = commands.add_parser(
        "plan", help="perceive the cut and plan the knife at the ready poses (no physics)")
    plan.add_argument("scenario", type=Path, help="scenario TOML file")
    plan.add_argument("--json", type=Path, required=True, help="write the plan's figures here")
    plan.add_argument("--seed", type=int, help="override the scenario's seed (sensor noise)")
    plan.set_defaults(handler=_plan)

    export = commands.add_parser("export-mjcf", help="write the scene as MJCF")
    export.add_argument("scenario", type=Path)
    export.add_argument("output", type=Path)
    export.set_defaults(handler=_export)

    diagnosis = commands.add_parser(
        "diagnose", help="diagnose a measurement set: what the simulation gets wrong, the "
        "cause, the extended material and the gain on held-out tests")
    diagnosis.add_argument("set_dir", type=Path, nargs="?",
                           help="folder with specimen.toml and tests.csv")
    diagnosis.add_argument("--json", type=Path, help="write the diagnosis here")
    diagnosis.add_argument("--material", type=Path,
                           help="write the extended material TOML here (default: next to the "
                           "JSON, <name>-material.toml)")
    diagnosis.add_argument("--report", type=Path,
                           help="write plots and a Markdown report in this folder")
    diagnosis.add_argument("--batch", type=Path,
                           help="diagnose every set in this folder, one Ray task each, into "
                           "one table in --out (needs the scale extra unless --workers 1)")
    diagnosis.add_argument("--out", type=Path,
                           help="--batch: results folder; sets already in it are skipped")
    diagnosis.add_argument("--quiet", action="store_true", help="--batch: no progress bar")
    add_workers(diagnosis, "; one set: processes fitting candidates side by side (default: "
                "every core)")
    diagnosis.set_defaults(handler=_diagnose)

    bench = commands.add_parser(
        "bench", help="benchmark the cell, the tissue models or the perception")
    bench.add_argument("suite", nargs="?",
                       choices=("cell", "tissue", "perception", "env", "diagnose", "sweep"),
                       default="cell",
                       help="cell: the whole cell (default); tissue: every tissue model on "
                       "the two muscles, with peers; perception: curvature, guideline and fit, "
                       "with peers; env: Gymnasium env steps per second; diagnose: the "
                       "diagnosis on unseen hidden-effect measurement sets")
    bench.add_argument("--scenario", type=Path, default=Path("scenarios/default.toml"),
                       help="scenario of the cell and perception suites")
    bench.add_argument("--json", type=Path,
                       help="JSON out (default out/bench.json, tissue: out/bench_tissue.json, "
                       "perception: out/bench_perception.json, env: out/bench_env.json, "
                       "diagnose: out/bench_diagnose.json, sweep: out/bench_sweep.json)")
    bench.add_argument("--markdown", type=Path,
                       help="tissue suite: Markdown tables out; diagnose: the confusion table")
    bench.add_argument("--seeds", type=int,
                       help="diagnose suite: number of sets (default 10, --quick 3)")
    bench.add_argument("--pairs", action="store_true",
                       help="diagnose suite: sets hiding two causes at once")
    bench.add_argument("--subtle", action="store_true",
                       help="diagnose suite: sets hiding one cause, half as strong")
    bench.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                       help="diagnose suite: processes per diagnosis (default: every core)")
    bench.add_argument("--shapes", type=int, default=0, help="perception: + N shape episodes")
    bench.add_argument("--shape-seed", type=int, default=5000)
    bench.add_argument("--quick", action="store_true",
                       help="fewer repetitions and a short episode; tissue: the smallest "
                       "mesh only (for smoke tests)")
    bench.set_defaults(handler=_bench)
    _add_learning(commands)
    add_sweep(commands)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``musclecell`` console script.

    It chooses headless rendering (``MUJOCO_GL=egl`` unless set) before any handler imports
    MuJoCo, which reads the variable at its own import.
    """
    os.environ.setdefault("MUJOCO_GL", "egl")
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
