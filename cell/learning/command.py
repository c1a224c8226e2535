"""The command-line side of learning: ``musclecell learn`` and ``musclecell evaluate``.

Light at import (the parser is built for every command): the handlers import the rest, and
Stable-Baselines3 (the ``learn`` extra) only when it is there.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING

from cell.cores import default_workers, usable_cores
from cell.errors import LearningError
from cell.options import add_out, add_quiet
from cell.outputs import Output, check_outputs

if TYPE_CHECKING:
    from cell.learning.ppo import LearnResult


def add_learning(commands: argparse._SubParsersAction) -> None:
    """The ``learn`` and ``evaluate`` subcommands."""
    from cell.learning.hyper import CONSTANT_LEVELS, EVAL_SEED_START, TUNING_SEED_START

    learn = commands.add_parser(
        "learn", help="train a PPO policy on an env (needs the learn extra)")
    learn.add_argument("env", metavar="ENV", help="Gymnasium id, e.g. musclecell/Cut-v2 or Cut-v2")
    learn.add_argument("--algo", choices=("ppo",), default="ppo", help="algorithm (ppo)")
    learn.add_argument("--steps", type=int, required=True,
                       help="env steps of the whole run, those before a --resume included")
    add_out(learn, "folder of the run", required=True, folder=True)
    learn.add_argument("--seed", type=int, default=0,
                       help=f"env i starts at seed SEED + i (training seeds < "
                       f"{EVAL_SEED_START}); default 0")
    learn.add_argument("--envs", type=int, help="envs side by side (default: one per core, "
                       "or one per CPU of the --address cluster)")
    learn.add_argument("--address", help="Ray cluster whose workers play the envs, one actor "
                       "each (the learner stays here): auto, HEAD_HOST:PORT or "
                       "ray://HOST:PORT (needs the scale extra; default: processes here)")
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
                       "the observation before PPO: table-skimming-knife (Cut), "
                       "hold-then-pull-away (Pull), steering-knife (Steer)")
    learn.add_argument("--warm-start-episodes", type=int, default=24,
                       help="the demonstrator's episodes to clone (default 24)")
    learn.add_argument("--warm-start-anchor", type=int, default=0, metavar="EPOCHS",
                       help="after each PPO update, passes of the cloning loss over its "
                       "rollout, holding PPO near the demonstrator (default 0: none)")
    add_quiet(learn)
    learn.set_defaults(handler=learn_command)

    evaluation = commands.add_parser(
        "evaluate", help="evaluate a learned policy beside the random, best constant, "
        "scripted and hand-written (demonstrator) policies on the same seeds; without a "
        "policy, the baselines alone")
    evaluation.add_argument("policy", type=Path, nargs="?", metavar="POLICY",
                            help="learn output folder (or a checkpoint's, or its policy.json); "
                            "leave it out to evaluate the baselines alone (then --out is "
                            "needed)")
    evaluation.add_argument("env", metavar="ENV",
                            help="Gymnasium id, e.g. musclecell/Cut-v2 or Cut-v2")
    evaluation.add_argument("--episodes", type=int, default=50, help="per policy (default 50)")
    evaluation.add_argument("--seed-start", type=int, default=EVAL_SEED_START,
                            help=f"first evaluation seed (default {EVAL_SEED_START})")
    add_out(evaluation, "folder of evaluation.json, evaluation.md and episodes.csv (default: "
            "POLICY's folder/evaluation; needed without POLICY)", folder=True)
    evaluation.add_argument("--json", type=Path, metavar="FILE",
                            help="the report JSON here instead of in --out's folder")
    evaluation.add_argument("--markdown", type=Path, metavar="FILE",
                            help="the Markdown table here instead of in --out's folder")
    evaluation.add_argument("--workers", type=int, help="processes (default: MUSCLECELL_WORKERS)")
    evaluation.add_argument("--env-kwargs", help="JSON keyword arguments of the env")
    evaluation.add_argument("--constant-search-seeds", type=int, default=10,
                            help=f"tuning episodes per constant action, seeds "
                            f"{TUNING_SEED_START} on (default 10)")
    evaluation.add_argument("--constant-actions",
                            help="JSON list of the constant actions to choose from (default: "
                            "zero and each axis alone at plus and minus "
                            f"{', '.join(f'{v:g}' for v in CONSTANT_LEVELS)}; then the best "
                            "of them with a second axis at those levels)")
    add_quiet(evaluation)
    evaluation.set_defaults(handler=evaluate_command)

    convert = commands.add_parser(
        "convert-policy", help="convert a run saved by an earlier release (pickled "
        "policy.zip, vecnormalize.pkl) to the numbers-and-JSON policy files; unpickling runs "
        "the files' code, so it needs --trust-pickle")
    convert.add_argument("run", type=Path, metavar="RUN",
                         help="learn output folder (its checkpoints too)")
    convert.add_argument("--trust-pickle", action="store_true",
                         help="you trust the run's source: its pickles may be loaded")
    convert.set_defaults(handler=convert_command)


def _require_learn_extra() -> None:
    """Stable-Baselines3 (and torch) are the ``learn`` extra, not a dependency."""
    import importlib.util

    if importlib.util.find_spec("stable_baselines3") is None:
        raise LearningError(None, None, "training and evaluation need the learn extra: "
                            "pip install -e '.[learn]', torch's CPU wheel first "
                            "(docs/getting-started.md)")


def learn_command(args: argparse.Namespace) -> int:
    """``musclecell learn``: a new run in ``--out``, or ``--resume`` of the run there."""
    check_outputs([Output(args.out, "--out", folder=True)])
    _require_learn_extra()
    from cell.learning.environments import resolve_env_id
    from cell.progress import progress_bar

    env_id = resolve_env_id(args.env)
    with ExitStack() as session:  # joined once: training itself joins this session
        envs = args.envs if args.envs is not None else usable_cores()
        if args.address is not None:
            from cell.learning.environments import WITHOUT_RAY
            from cell.rayconnect import ray_session

            ray = session.enter_context(ray_session(args.address, "--address", WITHOUT_RAY))
            if args.envs is None:
                envs = int(ray.cluster_resources().get("CPU", 1))
        with progress_bar("step", quiet=args.quiet,
                          total=None if args.resume else args.steps, desc="learn") as bar:
            result = _train(args, env_id, envs, bar.update)
    print(f"trained {result.steps} env steps in {result.wall_s:.1f} s (stopped by "
          f"{result.stopped_by}); wrote {result.out}")
    return 0


def _train(args: argparse.Namespace, env_id: str, envs: int,
           on_steps: Callable[[int], object]) -> LearnResult:
    """A new run, or ``--resume`` of the one in ``--out``: its options checked, trained."""
    from cell.learning import ppo
    from cell.learning.hyper import LearnSettings, PPOHyper, WarmStart, parse_json_object

    if args.resume:
        if args.env_kwargs is not None or args.hyper is not None or args.warm_start:
            raise LearningError(None, "--resume", "continues the run as it was set: drop "
                                "--env-kwargs, --hyper and --warm-start")
        return ppo.resume(args.out, env_id, args.steps, envs, args.minutes,
                          args.checkpoint_every, on_steps, args.address)
    if args.warm_start_anchor and not args.warm_start:
        raise LearningError(None, "--warm-start-anchor", "needs --warm-start")
    warm = (WarmStart(args.warm_start, episodes=args.warm_start_episodes,
                      anchor_epochs=args.warm_start_anchor) if args.warm_start else None)
    settings = LearnSettings(env_id, parse_json_object(args.env_kwargs, "--env-kwargs"),
                             args.seed, envs, args.steps, args.minutes,
                             args.checkpoint_every, warm, args.address)
    hyper = PPOHyper().with_overrides(parse_json_object(args.hyper, "--hyper"))
    return ppo.learn(settings, hyper, args.out, on_steps)


def evaluate_command(args: argparse.Namespace) -> int:
    """``musclecell evaluate``: the report's three files checked, then the episodes."""
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
        args.episodes, args.seed_start, args.workers or default_workers(),
        args.constant_search_seeds, parse_constant_actions(args.constant_actions))
    if args.policy is None and args.out is None:
        raise LearningError(None, "--out", "needed when no POLICY is given (the baselines "
                            "alone have no run folder to write in)")
    folder = None if args.policy is None else policy_folder(args.policy)
    out = args.out or folder / "evaluation"
    json_path = args.json or out / "evaluation.json"
    markdown_path = args.markdown or out / "evaluation.md"
    csv_path = out / "episodes.csv"
    check_outputs([Output(json_path, "--json" if args.json else "--out"),
                   Output(markdown_path, "--markdown" if args.markdown else "--out"),
                   Output(csv_path, "--out")], [] if args.policy is None else [args.policy])
    from cell.progress import progress_bar

    with progress_bar("episode", quiet=args.quiet, desc="evaluate") as bar:
        report = evaluate(folder, resolve_env_id(args.env),
                          parse_json_object(args.env_kwargs, "--env-kwargs"), settings,
                          bar.update)
    write_report(report, json_path, markdown_path, csv_path)
    print(report_markdown(report), end="")
    print(f"wrote {json_path}, {markdown_path} and {csv_path}")
    return 0


def convert_command(args: argparse.Namespace) -> int:
    """``musclecell convert-policy``: the pickled run and its checkpoints converted."""
    _require_learn_extra()
    from cell.learning.convert import convert_run

    for folder in convert_run(args.run, args.trust_pickle):
        print(f"converted {folder}")
    return 0
