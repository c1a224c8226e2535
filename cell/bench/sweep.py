"""``musclecell bench sweep``: the example sweep (24 scripted episodes on coarse tissue) on a
local Ray with one worker and with two: the speed-up of two over one, and what Ray costs per
run.

Ray's overhead per run is measured on the one-worker sweep, whose runs follow one another:
the time that played them, less Ray's start and less the runs' own wall time (measured in
the worker around each run), over the runs. It holds the tasks' submission and return, the
worker process's start and imports, and the results kept after each run. A trivial task's
round trip on a running Ray is reported beside it.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

from cell.bench.parts import Progress, measured
from cell.cores import usable_cores
from cell.scale.pool import RunPool, Workers
from cell.scale.sweep import SweepOutcome, run_sweep
from cell.sim.examples import SCENARIOS

EXAMPLE_SWEEP = SCENARIOS / "sweeps" / "binding_strength.toml"
#: Issue 15's targets: two workers at least this much faster than one; Ray's own cost per
#: run below this, s.
TARGET_SPEEDUP = 1.7
TARGET_OVERHEAD_S = 1.0
_ROUND_TRIPS = 50


def run_sweep_bench(sweep_file: Path = EXAMPLE_SWEEP, progress: Progress = None
                    ) -> dict[str, Any]:
    """Both sweeps, one after the other, each into a fresh folder (``progress`` hears of each
    as it finishes); the JSON-ready report."""
    round_trip_s = task_round_trip_s()

    def sweep(workers: int) -> SweepOutcome:
        with tempfile.TemporaryDirectory() as out:
            return run_sweep(sweep_file, out, Workers(workers, ray=True), progress=False)

    outcomes = measured({"sweep with 1 worker": lambda: sweep(1),
                         "sweep with 2 workers": lambda: sweep(2)}, progress)
    one, two = outcomes["sweep with 1 worker"], outcomes["sweep with 2 workers"]
    runs = len(one.rows)
    run_s = sum(row.get("wall_s", 0.0) for row in one.rows)
    overhead = (one.play_s - one.startup_s - run_s) / runs
    speedup = one.wall_s / two.wall_s
    entries = {
        "sweep_speedup_2_over_1": {"value": speedup, "unit": "x", "target": TARGET_SPEEDUP,
                                   "pass": speedup >= TARGET_SPEEDUP},
        "ray_overhead_per_run": {"value": overhead, "unit": "s", "target": TARGET_OVERHEAD_S,
                                 "pass": overhead < TARGET_OVERHEAD_S},
        "sweep_wall_1_worker": {"value": one.wall_s, "unit": "s"},
        "sweep_wall_2_workers": {"value": two.wall_s, "unit": "s"},
        "run_wall_mean": {"value": run_s / runs, "unit": "s"},
        "ray_start": {"value": one.startup_s, "unit": "s"},
        "ray_task_round_trip": {"value": round_trip_s, "unit": "s"},
    }
    statuses = {s: sum(row["status"] == s for row in two.rows) for s in ("ok", "diverged",
                                                                        "failed")}
    return {"sweep": str(sweep_file), "runs": runs, "cores": usable_cores(),
            "statuses_2_workers": statuses, "entries": entries}


def task_round_trip_s() -> float:
    """Mean wall time of a trivial Ray task, submitted and awaited one at a time, s."""
    with RunPool(Workers(2)) as pool:
        list(pool.play(_echo, [0], ["warm-up"]))
        start = time.perf_counter()
        for k in range(_ROUND_TRIPS):
            list(pool.play(_echo, [k], ["round-trip"]))
        return (time.perf_counter() - start) / _ROUND_TRIPS


def _echo(value: int) -> int:
    """A task that does nothing (Ray's remote functions must be Python functions)."""
    return value
