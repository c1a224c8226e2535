"""Soak test of ``musclecell/Cut-v2``: does one process's memory stay flat over many episodes?

Each iteration resets the coarse env with seed ``i`` (a freshly built cell in a drawn world)
and takes a few random steps; the resident set size (RSS, from ``/proc/self/statm``) is read
after every reset. The JSON report holds the RSS after every reset, at reset ``--warmup``
(caches filled by then) and at the end, the growth between those two in percent, the wall
time, and ``pass``: growth under 5 %.

Usage (about 1 to 1.5 s a reset on one core)::

    .venv/bin/python scripts/soak_env.py --out out/soak_env.json
    .venv/bin/python scripts/soak_env.py --resets 200 --steps-per-reset 5 --out out/soak.json
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import gymnasium as gym

import envs  # noqa: F401  (registers the ids)
from cell.options import add_out
from cell.outputs import write_json

#: Most RSS growth, in percent, from the warm-up reset to the last, for a pass.
MAX_GROWTH_PERCENT = 5.0
_MIB = 2**20


def rss_mib() -> float:
    """This process's resident set size now, MiB."""
    with open("/proc/self/statm") as statm:
        resident_pages = int(statm.read().split()[1])
    return resident_pages * os.sysconf("SC_PAGE_SIZE") / _MIB


def soak(resets: int, steps_per_reset: int, warmup: int) -> dict[str, object]:
    """Reset and step the coarse Cut-v2 ``resets`` times; returns the report."""
    env = gym.make("musclecell/Cut-v2")
    env.action_space.seed(0)
    rss = []
    start = time.perf_counter()
    for i in range(resets):
        env.reset(seed=i)
        rss.append(rss_mib())
        for _ in range(steps_per_reset):
            _, _, terminated, truncated, _ = env.step(env.action_space.sample())
            if terminated or truncated:
                break
        if (i + 1) % 100 == 0:
            print(f"reset {i + 1}: RSS {rss[-1]:.1f} MiB, {time.perf_counter() - start:.0f} s",
                  flush=True)
    wall_s = time.perf_counter() - start
    env.close()
    at_warmup, at_end = rss[warmup - 1], rss[-1]
    growth = 100.0 * (at_end - at_warmup) / at_warmup
    return {"env": "musclecell/Cut-v2", "resets": resets, "steps_per_reset": steps_per_reset,
            "warmup_resets": warmup, "rss_at_warmup_mib": at_warmup, "rss_at_end_mib": at_end,
            "growth_percent": growth, "max_growth_percent": MAX_GROWTH_PERCENT,
            "pass": growth < MAX_GROWTH_PERCENT, "wall_time_s": wall_s,
            "seconds_per_reset": wall_s / resets, "rss_mib": [round(r, 2) for r in rss]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resets", type=int, default=1000)
    parser.add_argument("--steps-per-reset", type=int, default=5)
    parser.add_argument("--warmup", type=int, default=100,
                        help="the reset whose RSS the growth is measured from")
    add_out(parser, "the report JSON (default out/soak_env.json)", old=("--json",))
    args = parser.parse_args()
    out = args.out or Path("out/soak_env.json")
    if not 1 <= args.warmup < args.resets:
        parser.error("--warmup must be at least 1 and below --resets")
    report = soak(args.resets, args.steps_per_reset, args.warmup)
    write_json(out, report)
    print(f"RSS {report['rss_at_warmup_mib']:.1f} MiB at reset {args.warmup}, "
          f"{report['rss_at_end_mib']:.1f} MiB at the end: {report['growth_percent']:+.2f} % "
          f"({'pass' if report['pass'] else 'FAIL'}), {report['wall_time_s']:.0f} s")


if __name__ == "__main__":
    main()
