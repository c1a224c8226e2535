"""``Steer-v2``'s learned policy in one run: DAgger from the expert that steers on
the true interface (cell.learning.dagger), the learner seeing only its own observation, on
training seeds from ``--seed``; its learning curve in OUT/run; then the learned policy beside
no steering, the steering rule and the ceiling on the evaluation seeds (100000 on), paired on
the same seeds (cell.learning.headroom), in OUT/headroom.json. With ``--average-rounds``, the
run's last network and its average over the rounds (OUT/run/average) are played on
``--validation-episodes`` tuning seeds (300300 on) and the one nearer the interface is the
learned policy evaluated. ``--minutes`` bounds the training (no round starts that would end
after it); the evaluation of 200 seeds plays 800 episodes after it."""

import argparse
import json
from pathlib import Path

from cell.learning.dagger import AVERAGE_FOLDER, DaggerSettings, train
from cell.learning.headroom import (
    VALIDATION_SEED_START,
    baseline_table,
    choose_learned,
    summary_lines,
)
from cell.outputs import write_json


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=Path("out/steer"))
    parser.add_argument("--minutes", type=float, default=40.0, help="training's wall clock")
    parser.add_argument("--rounds", type=int, default=200, help="at most (--minutes ends it)")
    parser.add_argument("--episodes", type=int, default=16, help="per round")
    parser.add_argument("--fit-batches", type=int, default=1000, help="Adam steps per round")
    parser.add_argument("--average-rounds", type=int, default=20, help="also save an "
                        "exponential average of the rounds' networks over about this many "
                        "(0: none)")
    parser.add_argument("--validation-episodes", type=int, default=40, help="tuning seeds "
                        "that choose between the last network and the average")
    parser.add_argument("--seed", type=int, default=0, help="first training seed")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--env-kwargs", default="{}", help="JSON keyword arguments of the env")
    parser.add_argument("--rule", default="{}", help="JSON settings of the rule (its "
                        "defaults: the tuned ones)")
    parser.add_argument("--eval-episodes", type=int, default=200, help="0: no evaluation")
    parser.add_argument("--eval-seed-start", type=int, default=100_000)
    args = parser.parse_args()
    env_kwargs = json.loads(args.env_kwargs)
    # The network steers (the across offset); the depth is the rule's and no steering's own
    # servo, so that the comparison is of the steering alone.
    settings = DaggerSettings(env_kwargs=env_kwargs, seed=args.seed, rounds=args.rounds,
                              episodes=args.episodes, fit_batches=args.fit_batches,
                              workers=args.workers, minutes=args.minutes,
                              average_rounds=args.average_rounds,
                              base="table-skimming-knife", learned=(1,))
    run = args.out / "run"
    run.mkdir(parents=True, exist_ok=True)

    def report(row: dict) -> None:
        tip = "-" if row["tip_mean_mm"] is None else f"{row['tip_mean_mm']:.2f}"
        print(f"round {row['round']} ({row['played_by']}): {row['env_steps']} steps, "
              f"{row['wall_s']:.0f} s, tip {tip} mm ({row['tip_scored']} scored), success "
              f"{row['success_rate']:.2f}, fit mse {row['action_mse']:.2e}", flush=True)

    record = train(settings, run, report)
    print(f"trained {len(record['curve'])} rounds in {record['wall_s'] / 60:.1f} min "
          f"(stopped by {record['stopped_by']}): {run}", flush=True)
    if args.eval_episodes == 0:
        return
    learned, validation = str(run), None
    if args.average_rounds and args.validation_episodes:
        validation = choose_learned(
            [str(run), str(run / AVERAGE_FOLDER)],
            range(VALIDATION_SEED_START, VALIDATION_SEED_START + args.validation_episodes),
            args.workers, env_kwargs)
        learned = validation["chosen"]
        for score in validation["scores"]:
            print(f"validation {score['folder']}: tip {score['tip_mean_mm']} mm, success "
                  f"{score['success_rate']:.2f}", flush=True)
    seeds = range(args.eval_seed_start, args.eval_seed_start + args.eval_episodes)
    evaluation = baseline_table(json.loads(args.rule), seeds, args.workers, env_kwargs,
                                learned)
    write_json(args.out / "headroom.json", {"validation": validation, "learned": learned,
                                            "evaluation": evaluation})
    print("\n".join(summary_lines(evaluation)))


if __name__ == "__main__":
    main()
