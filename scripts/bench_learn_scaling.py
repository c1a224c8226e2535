"""``learn --envs 2`` over ``--envs 1`` alone (the ``learn_scaling_2_over_1`` entry of
``musclecell bench env``): two ``learn`` runs of the same steps per env and per update, their
env steps per second and ratio, with the load average, as JSON. Run it on otherwise idle
cores; the benchmarks page gives its duration."""

import argparse
from pathlib import Path

from cell.bench.env import LEARN_SCALING_STEPS, bench_learn_scaling
from cell.options import add_out
from cell.outputs import write_json


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps-per-env", type=int, default=LEARN_SCALING_STEPS[0])
    parser.add_argument("--n-steps", type=int, default=LEARN_SCALING_STEPS[1],
                        help="env steps per env between updates")
    add_out(parser, "the report JSON (default out/bench_learn_scaling.json)", old=("--json",))
    args = parser.parse_args()
    out = args.out or Path("out/bench_learn_scaling.json")
    entry = bench_learn_scaling(args.steps_per_env, args.n_steps)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_json(out, entry)
    print(f"learn --envs 2 over --envs 1: {entry['value']:.2f} (target {entry['target']}: "
          f"{'pass' if entry['pass'] else 'FAIL'}); envs 1 {entry['envs1']['value']:.0f}, "
          f"envs 2 {entry['envs2']['value']:.0f} env steps/s; load {entry['load_1min']}; "
          f"wrote {out}")


if __name__ == "__main__":
    main()
