"""``musclecell bench``: speed figures of the cell, each beside a peer measured in the same run.

Entries (``value`` in ``unit``; ``peer`` and ``ratio`` = value / peer where a peer applies):

- ``physics_us_per_node_step``: wall time of one physics step of the whole cell (arms, tools,
  muscles, bindings, contacts) per tissue node; peer: the same cell with MuJoCo's own flex
  continuum muscles.
- ``episode_real_time_factor``: simulated over wall time of the scripted episode (no
  recording); with ``--quick`` the episode is cut short.
- ``ik_ms_per_control_step``: one solve of the three-arm IK; peer: one Viper alone.
- ``trajectory_s``: the wall time of what ``run --trajectory`` adds (sampling the arms and
  the sensors at every control step, the limits report, the MCAP file's content); peer: the
  episode's own wall time (its run: perception, plan, control loop), so ``ratio`` is the
  share it adds.
"""

from __future__ import annotations

import os
import platform
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import mink
import mujoco
import numpy as np

from cell.robots.arms import build_arm
from cell.robots.dh import VIPER_S1700D
from cell.sim.episode import Episode
from cell.sim.scenario import Scenario, load_scenario
from cell.sim.trajectory import TrajectorySampler
from cell.sim.trajectoryfiles import program_output
from cell.tissue.material import ContinuumMaterial


def _cell_step_us_per_node(scenario: Scenario, steps: int) -> tuple[float, int]:
    """Wall time of one :meth:`Simulation.step` of the whole cell (springs, bindings,
    contacts, arms) per tissue node, us; and the node count."""
    sim = Episode(scenario).sim
    sim.step(steps // 4)  # let contacts form before timing
    start = time.perf_counter()
    sim.step(steps)
    nodes = sim.scene.node_count
    return (time.perf_counter() - start) / steps / nodes * 1e6, nodes


def bench_physics(scenario: Scenario, steps: int) -> dict[str, Any]:
    cell, nodes = _cell_step_us_per_node(scenario, steps)
    continuum = replace(scenario, material=ContinuumMaterial(),
                        simulation=replace(scenario.simulation, integrator="auto"))
    peer, _ = _cell_step_us_per_node(continuum, steps)
    return {"value": cell, "unit": "us/node/step", "peer": peer,
            "peer_name": "same cell with MuJoCo's flex continuum (StVK) muscles",
            "ratio": cell / peer, "nodes": nodes, "material": type(scenario.material).__name__,
            "timestep_s": scenario.simulation.timestep_s}


def bench_episode(scenario: Scenario, quick: bool) -> dict[str, Any]:
    if quick:
        scenario = replace(scenario, end_s=3.0)
    summary = Episode(scenario).run()
    return {"value": summary["timing"]["real_time_factor"], "unit": "x real time",
            "sim_time_s": summary["result"]["sim_time_s"],
            "wall_time_s": summary["timing"]["wall_time_s"], "truncated": quick}


def bench_trajectory(scenario: Scenario, quick: bool) -> dict[str, Any]:
    if quick:
        scenario = replace(scenario, end_s=3.0)
    episode = Episode(scenario)
    sampler = TrajectorySampler.attach(episode)
    start = time.perf_counter()
    episode.run()
    wall_s = time.perf_counter() - start
    output = program_output(episode, sampler, ".mcap")
    return {"value": output.cost_s, "unit": "s", "peer": wall_s,
            "peer_name": "the episode's own wall time", "ratio": output.cost_s / wall_s,
            "control_steps": output.trajectory.steps, "truncated": quick}


def bench_ik(scenario: Scenario, solves: int) -> dict[str, Any]:
    episode = Episode(scenario)
    ik = episode.ik
    dt = episode.control_dt_s
    position, rotation = ik.site_pose("knife/tip")
    start = time.perf_counter()
    for k in range(solves):
        target = position + np.array([0.0005 * k, 0.0, 0.0])
        ik.knife.set_target(mink.SE3.from_rotation_and_translation(
            mink.SO3.from_matrix(rotation), target))
        ik.solve(dt)
    cell = (time.perf_counter() - start) / solves * 1e3

    arm = build_arm(VIPER_S1700D).compile()
    configuration = mink.Configuration(arm, np.array(VIPER_S1700D.home_q_rad))
    task = mink.FrameTask("flange", "site", position_cost=1.0, orientation_cost=0.5)
    task.set_target_from_configuration(configuration)
    goal = task.transform_target_to_world
    limits = [mink.ConfigurationLimit(arm)]
    start = time.perf_counter()
    for k in range(solves):
        task.set_target(mink.SE3.from_rotation_and_translation(
            goal.rotation(), goal.translation() + np.array([0.0005 * k, 0.0, 0.0])))
        velocity = mink.solve_ik(configuration, [task], dt, "daqp", limits=limits)
        configuration.integrate_inplace(velocity, dt)
    peer = (time.perf_counter() - start) / solves * 1e3
    return {"value": cell, "unit": "ms/solve", "peer": peer,
            "peer_name": "one Viper, one frame task", "ratio": cell / peer,
            "joints": int(episode.robot_model.nv)}


def run_bench(scenario_path: str | Path, quick: bool = False) -> dict[str, Any]:
    """Run every entry on the scenario; returns the JSON-ready report."""
    scenario = load_scenario(scenario_path)
    entries = {
        "physics_us_per_node_step": bench_physics(scenario, 50 if quick else 300),
        "ik_ms_per_control_step": bench_ik(scenario, 50 if quick else 500),
        "episode_real_time_factor": bench_episode(scenario, quick),
        "trajectory_s": bench_trajectory(scenario, quick),
    }
    return {
        "scenario": str(scenario_path),
        "machine": {"python": platform.python_version(), "processor": platform.machine(),
                    "mujoco": mujoco.__version__, "cpus": cpu_count()},
        "entries": entries,
    }


def cpu_count() -> int:
    """CPUs this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
