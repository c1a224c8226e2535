"""``musclecell bench env``: env steps per second of ``musclecell/Cut-v2``, one env and eight
vectorised (synchronously, in one process), at the coarse and the default tissue resolution,
one env per core each alone in its own process (``processes``: parallel runs, evaluation
workers) and one env per core in an asynchronous vector env (``async``: lock-step, as
training's ``--envs``), each with its ``scaling``, its rate over the single env's: near the
core count when the processes scale; and, asked for (``--learn``, the learn extra),
``learn_scaling_2_over_1``:
``musclecell learn`` with two envs over one, its training loop whole (resets, the policy, PPO's
updates); with ``--address`` too, ``learn_ray_over_1``: ``learn --address`` with one env per
CPU of that Ray cluster (:mod:`cell.learning.rayenvs`) over one env here.

One env step is one control step (20 ms: 4 physics steps of 5 ms, the implicit tissue step).
Each single-env entry splits a step's wall time into physics (:meth:`Simulation.step`, MuJoCo
and the tissue forces), IK (the three-arm mink solve) and the rest (release rules, sensing,
observation, reward: Python overhead). Independent processes scale near the core count; the
lock-step vector env less, because each of its steps waits for the slower env and for the
pipes, and its main process takes a share of the cores. ``learn`` trains on rollouts that each
env process collects alone (:mod:`cell.learning.segmentppo`): the envs meet once per rollout,
not at every step and every reset. The figures are on the docs' benchmarks page.
"""

from __future__ import annotations

import multiprocessing
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from cell.bench.parts import Progress, measured
from cell.cores import usable_cores
from cell.learning.environments import START_METHOD
from cell.tissue.geometry import MuscleShape

#: Target for one env at the coarse resolution on one core, env steps per second.
TARGET_STEPS_PER_S = 500.0
#: Target of ``learn --envs 2`` over ``--envs 1``, env steps per second.
LEARN_SCALING_TARGET = 1.6
#: The full bench's ``learn`` runs: env steps per env and per env between updates (about five
#: minutes of ``--envs 1`` on one core, PPO's default rollout).
LEARN_SCALING_STEPS = (65536, 1024)


class _Stopwatch:
    """Accumulates the wall time of the calls it wraps."""

    def __init__(self) -> None:
        self.seconds = 0.0

    def wrap(self, function: Callable[..., Any]) -> Callable[..., Any]:
        def timed(*args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - start
        return timed


def bench_single(cell_size_m: float, steps: int) -> dict[str, Any]:
    """One env: steps per second and the per-step split, ms."""
    import envs

    env = envs.CutEnv(cell_size_m=cell_size_m, time_limit_s=10 * steps)
    env.reset(seed=0)
    physics, ik = _Stopwatch(), _Stopwatch()
    # Wrapped on the instances, so that the timing covers exactly this env's calls.
    env.episode.sim.step = physics.wrap(env.episode.sim.step)
    env.episode.ik.solve = ik.wrap(env.episode.ik.solve)
    action = np.array([0.4, 0.0, 0.0, 0.0], dtype=np.float32)
    start = time.perf_counter()
    for _ in range(steps):
        env.step(action)
    wall = time.perf_counter() - start
    per_step = {"total": wall / steps * 1e3, "physics": physics.seconds / steps * 1e3,
                "ik": ik.seconds / steps * 1e3}
    per_step["python_overhead"] = per_step["total"] - per_step["physics"] - per_step["ik"]
    return {"value": steps / wall, "unit": "env steps/s", "ms_per_step": per_step,
            "tissue_nodes": env.episode.scene.node_count, "cell_size_m": cell_size_m}


def bench_vector(cell_size_m: float, steps: int, num_envs: int = 8,
                 mode: str = "sync") -> dict[str, Any]:
    """``num_envs`` envs in a vector env, in one process (``sync``) or one process each
    (``async``): env steps (all envs) per second."""
    import envs  # noqa: F401  (registers the ids)

    vector_kwargs = {"context": START_METHOD} if mode == "async" else {}
    vec = gym.make_vec("musclecell/Cut-v2", num_envs=num_envs, vectorization_mode=mode,
                       vector_kwargs=vector_kwargs, cell_size_m=cell_size_m,
                       time_limit_s=10 * steps)
    vec.reset(seed=0)
    actions = np.tile(np.array([0.4, 0.0, 0.0, 0.0], dtype=np.float32), (num_envs, 1))
    start = time.perf_counter()
    for _ in range(steps):
        vec.step(actions)
    wall = time.perf_counter() - start
    vec.close()
    return {"value": num_envs * steps / wall, "unit": "env steps/s", "num_envs": num_envs,
            "mode": mode, "cell_size_m": cell_size_m}


def _single_rate(cell_size_m: float, steps: int) -> float:
    return bench_single(cell_size_m, steps)["value"]


def bench_processes(cell_size_m: float, steps: int, processes: int) -> dict[str, Any]:
    """``processes`` envs, each alone in its own process (started as training's envs are),
    stepped at once: their rates summed, env steps/s."""
    context = multiprocessing.get_context(START_METHOD)
    with context.Pool(processes) as pool:
        rates = pool.starmap(_single_rate, [(cell_size_m, steps)] * processes)
    return {"value": sum(rates), "unit": "env steps/s", "processes": processes,
            "per_process": rates, "cell_size_m": cell_size_m}


def _learn_rate(envs: int, steps_per_env: int, n_steps: int, folder: Path,
                address: str | None = None) -> dict[str, Any]:
    """``musclecell learn Cut-v2`` on ``envs`` envs for ``steps_per_env`` env steps each,
    ``n_steps`` per env between updates (on the Ray cluster at ``address``, if any):
    Stable-Baselines3's own rate over the training loop (its last ``time/fps``: env steps
    since the loop began over its wall time, resets, policy, PPO updates and checkpoints
    included; env construction not)."""
    from cell.learning import ppo
    from cell.learning.hyper import LearnSettings, PPOHyper
    from cell.learning.logs import read_rows

    settings = LearnSettings("musclecell/Cut-v2", {}, seed=0, envs=envs,
                             steps=envs * steps_per_env, checkpoint_every=10**9,
                             address=address)
    hyper = PPOHyper(n_steps=n_steps, batch_size=min(256, n_steps))
    result = ppo.learn(settings, hyper, folder)
    fps = float(read_rows(folder / "progress.csv")[-1]["time/fps"])
    return {"value": fps, "unit": "env steps/s", "envs": envs, "steps": result.steps,
            "n_steps": n_steps, "wall_s": result.wall_s, "address": address}


def bench_learn_scaling(steps_per_env: int, n_steps: int, address: str | None = None
                        ) -> dict[str, Any]:
    """``learn --envs 2`` over ``learn --envs 1``, or with ``address`` ``learn --address``
    with one env per CPU of that cluster over ``learn --envs 1`` here, the same steps per env
    and per update: each run's rate (:func:`_learn_rate`) and their ratio, with the machine's
    load average (1 min) before and after: a ratio measured on busy cores says little."""
    import tempfile

    many = 2 if address is None else _cluster_cpus(address)
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as folder:
        one = _learn_rate(1, steps_per_env, n_steps, Path(folder) / "envs1")
        spread = _learn_rate(many, steps_per_env, n_steps, Path(folder) / f"envs{many}", address)
    ratio = spread["value"] / one["value"]
    return {"value": ratio, "unit": "ratio", "envs1": one, f"envs{many}": spread,
            "target": LEARN_SCALING_TARGET, "pass": ratio >= LEARN_SCALING_TARGET,
            "load_1min": [load_before, os.getloadavg()[0]], "cores": usable_cores()}


def _cluster_cpus(address: str) -> int:
    from cell.learning.environments import WITHOUT_RAY
    from cell.rayconnect import ray_session

    with ray_session(address, "--address", WITHOUT_RAY) as ray:
        return int(ray.cluster_resources().get("CPU", 1))


def run_env_bench(quick: bool = False, learn: bool = False, address: str | None = None,
                  progress: Progress = None) -> dict[str, Any]:
    """Every entry (``learn_scaling_2_over_1`` with ``learn`` only: it trains, and needs the
    learn extra; ``learn_ray_over_1`` with ``address`` too; ``progress`` hears of each as it
    finishes); returns the JSON-ready report."""
    steps = 30 if quick else 200
    coarse, default = 0.05, MuscleShape().cell_size_m
    cores = usable_cores()
    parts = {
        "single_coarse": lambda: bench_single(coarse, steps),
        "single_default": lambda: bench_single(default, steps),
        "vector8_coarse": lambda: bench_vector(coarse, steps // 2),
        "vector8_default": lambda: bench_vector(default, steps // 4),
        f"processes{cores}_coarse": lambda: bench_processes(coarse, steps, cores),
        f"async{cores}_coarse": lambda: bench_vector(coarse, steps, cores, mode="async"),
    }
    if learn:
        sizes = (128, 64) if quick else LEARN_SCALING_STEPS
        parts["learn_scaling_2_over_1"] = lambda: bench_learn_scaling(*sizes)
        if address is not None:
            parts["learn_ray_over_1"] = lambda: bench_learn_scaling(*sizes, address=address)
    entries = measured(parts, progress)
    for name in (f"processes{cores}_coarse", f"async{cores}_coarse"):
        entries[name]["scaling"] = entries[name]["value"] / entries["single_coarse"]["value"]
    entries["single_coarse"]["target"] = TARGET_STEPS_PER_S
    entries["single_coarse"]["pass"] = entries["single_coarse"]["value"] >= TARGET_STEPS_PER_S
    return {"env": "musclecell/Cut-v2", "entries": entries}
