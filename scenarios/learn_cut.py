"""Learn the knife on ``musclecell/Cut-v2`` with no deep-learning dependency: cross-entropy
search over a linear policy. Prints the population's mean return per iteration.

    python scenarios/learn_cut.py --iterations 8 --population 8 --json out/learn_cut.json

With PPO instead (the ``learn`` extra): ``musclecell learn Cut-v2 --steps 50000 --out
out/cut`` (docs/learning.md).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from cell.outputs import write_json
from envs import CutEnv
from envs.policies import CrossEntropyParams, cross_entropy_search, episode_return


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=8)
    parser.add_argument("--population", type=int, default=8)
    parser.add_argument("--elite", type=int, default=2)
    parser.add_argument("--time-limit-s", type=float, default=3.0,
                        help="simulated seconds of cutting per episode")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, help="write the learning curve here")
    args = parser.parse_args()
    env = CutEnv(time_limit_s=args.time_limit_s)
    params = CrossEntropyParams(iterations=args.iterations, population=args.population,
                                elite=args.elite)

    def report(iteration: int, returns: object) -> None:
        print(f"iteration {iteration}: mean return {returns.mean():.3f}, "
              f"best {returns.max():.3f}", flush=True)

    policy, curve = cross_entropy_search(env, params, args.seed, report)
    final, info = episode_return(env, policy, args.seed + args.iterations)
    print(f"final mean policy: return {final:.3f}, released {info['released_fraction']:.0%}")
    if args.json is not None:
        write_json(args.json, {"mean_return_per_iteration": curve, "final_return": final,
                               "final_released_fraction": info["released_fraction"]})


if __name__ == "__main__":
    main()
