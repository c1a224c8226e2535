"""``Steer-v2``'s headroom before training (cell.learning.headroom): the steering rule tuned on
tuning seeds (300000 on; every setting of its grid on ``--tune-episodes`` each, no steering
beside them), then no steering, the tuned rule and the ceiling on the evaluation seeds
(100000 on), as JSON with 95 % intervals and paired differences. ``--rule`` skips the tuning.
On two idle cores: about 30 minutes for the tuning's 200 episodes per setting, 5 for the
table's 50 seeds."""

import argparse
import json
from pathlib import Path

from cell.learning.headroom import baseline_table, summary_lines, tune_rule
from cell.options import add_out
from cell.outputs import write_json


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--tune-episodes", type=int, default=200)
    parser.add_argument("--rule", help="JSON settings of the rule (skips the tuning)")
    parser.add_argument("--episodes", type=int, default=50, help="evaluation seeds")
    parser.add_argument("--seed-start", type=int, default=100_000)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--env-kwargs", default="{}", help="JSON keyword arguments of the env")
    parser.add_argument("--learned", default="", help="a learn run's folder: its policy too")
    add_out(parser, "the report JSON (default out/steer_headroom.json)", old=("--json",))
    args = parser.parse_args()
    out = args.out or Path("out/steer_headroom.json")
    env_kwargs = json.loads(args.env_kwargs)
    report = {}
    if args.rule is None:
        report["tuning"] = tune_rule(args.tune_episodes, args.workers, env_kwargs)
        rule = report["tuning"]["chosen"]
    else:
        rule = json.loads(args.rule)
    seeds = range(args.seed_start, args.seed_start + args.episodes)
    report["evaluation"] = baseline_table(rule, seeds, args.workers, env_kwargs,
                                          args.learned)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_json(out, report)
    print("\n".join(summary_lines(report["evaluation"])))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
