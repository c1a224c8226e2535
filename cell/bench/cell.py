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
- ``episode_stepping_share``: the share of the episode's wall time (no recording; from the
  scene's build to the summary) in MuJoCo's step, the tissue law and its implicit solve;
  ``parts_s`` has every part (:mod:`cell.sim.profiled`), ``mujoco_step_s`` MuJoCo's stages.
- ``contact_load_us``: the load of the flex contacts on the knife and on the round (as the
  tools' sensors and the dynamometer read them), read at once from MuJoCo's contact
  arrays, at a state in the cut; peer: the same contacts one ``mj_contactForce`` call each.
- ``mesh_build_s``: building the two muscles' mesh of the scenario's shape; peer: building
  the whole scene it is part of (``ratio``: its share).
- ``episode_growth_exponent``: how the episode's wall time (build and run, no recording)
  grows with the tissue's nodes: the slope of log wall time on log nodes over the same
  scenario meshed at about :data:`GROWTH_NODES` nodes (finer cells); ``runs`` has each
  mesh's nodes, bindings and wall time, ``bindings_exponent`` the bindings' growth likewise.
"""

from __future__ import annotations

import platform
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import mink
import mujoco
import numpy as np

from cell.bench.parts import Progress, measured
from cell.cores import usable_cores
from cell.profiling import Profile
from cell.robots.arms import build_arm
from cell.robots.dh import VIPER_S1700D
from cell.robots.names import KNIFE_BLADE_GEOM
from cell.sim.assembly import build_scene
from cell.sim.dynamometer import contact_load
from cell.sim.episode import Episode
from cell.sim.profiled import EPISODE_PARTS, MUJOCO_STEP, add_mujoco_stages, start_episode
from cell.sim.scenario import Scenario, load_scenario
from cell.sim.trajectory import TrajectorySampler
from cell.sim.trajectoryfiles import program_output
from cell.tissue.geometry import build_two_muscles
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


def bench_mesh_build(scenario: Scenario, repeats: int) -> dict[str, Any]:
    mesh_s, scene_s = [], []
    for _ in range(repeats):
        start = time.perf_counter()
        build_two_muscles(scenario.tissue)
        mesh_s.append(time.perf_counter() - start)
        start = time.perf_counter()
        build_scene(scenario)
        scene_s.append(time.perf_counter() - start)
    mesh, scene = min(mesh_s), min(scene_s)
    return {"value": mesh, "unit": "s", "peer": scene, "peer_name": "the whole scene's build",
            "ratio": mesh / scene}


#: The node counts the growth entry aims its meshes at.
GROWTH_NODES = (500, 1000, 2000, 4000)


def bench_growth(scenario: Scenario, quick: bool) -> dict[str, Any]:
    if quick:
        scenario = replace(scenario, end_s=3.0)
    nodes_here = build_scene(scenario).node_count
    runs = []
    for target in GROWTH_NODES:
        cell_size_m, nodes = scenario.tissue.cell_size_m, nodes_here
        for _ in range(2):  # nodes go about as the inverse cube of the cell size; once more
            cell_size_m *= (nodes / target) ** (1.0 / 3.0)
            meshed = replace(scenario, tissue=replace(scenario.tissue, cell_size_m=cell_size_m))
            start = time.perf_counter()
            scene = build_scene(meshed)
            nodes = scene.node_count
        episode = Episode(meshed, scene)
        episode.run()
        runs.append({"cell_size_m": cell_size_m, "nodes": episode.sim.scene.node_count,
                     "bindings": len(episode.sim.scene.aponeurosis),
                     "wall_time_s": time.perf_counter() - start})
    log_nodes = np.log([run["nodes"] for run in runs])

    def exponent(key: str) -> float:
        return float(np.polyfit(log_nodes, np.log([run[key] for run in runs]), 1)[0])

    return {"value": exponent("wall_time_s"), "unit": "d log wall time / d log nodes",
            "bindings_exponent": exponent("bindings"), "runs": runs, "truncated": quick}


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
def bench_profile(scenario: Scenario, quick: bool) -> dict[str, Any]:
    if quick:
        scenario = replace(scenario, end_s=3.0)
    profile = Profile(EPISODE_PARTS)
    with profile.on():
        episode = start_episode(scenario)
        episode.run()
    profile.stop()
    add_mujoco_stages(profile, episode.sim.data)
    parts = profile.seconds_by_part()
    stepping = sum(parts[name] for name in (MUJOCO_STEP, "tissue law", "implicit solve"))
    return {"value": stepping / profile.total_s(), "unit": "share of the wall time",
            "total_s": profile.total_s(), "parts_s": parts,
            "mujoco_step_s": profile.details[MUJOCO_STEP], "truncated": quick}


def per_contact_load(model: mujoco.MjModel, data: mujoco.MjData, on_object: np.ndarray,
                     point_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~cell.sim.dynamometer.contact_load` one contact at a time, each by
    ``mujoco.mj_contactForce``: the peer of ``contact_load_us`` and the tests' reference."""
    force, moment, wrench = np.zeros(3), np.zeros(3), np.zeros(6)
    for i in np.flatnonzero(on_object[:, 0] != on_object[:, 1]):
        mujoco.mj_contactForce(model, data, i, wrench)
        world = data.contact.frame[i].reshape(3, 3).T @ wrench[:3]
        world = world if on_object[i, 1] else -world
        force += world
        moment += np.cross(data.contact.pos[i] - point_m, world)
    return force, moment


def contact_state(scenario: Scenario) -> Episode:
    """The episode stopped in its cut (the knife's flex contacts many), for the contact
    benchmark and the tests."""
    episode = Episode(scenario)
    plan = episode.plan()
    window = plan.cut_window_s
    for k in range(int(0.5 * (window.start_s + window.end_s) / episode.control_dt_s)):
        time_s = (k + 1) * episode.control_dt_s
        episode.control_step(plan, plan.knife.sample(time_s), plan.pull.sample(time_s))
    return episode


def bench_contacts(scenario: Scenario, repeats: int) -> dict[str, Any]:
    sim = contact_state(scenario).sim
    model, data = sim.model, sim.data
    count = data.ncon
    knife = model.geom_bodyid[model.geom(KNIFE_BLADE_GEOM).id]
    on_knife = (data.contact.geom[:count] >= 0) & (
        model.geom_bodyid[np.maximum(data.contact.geom[:count], 0)] == knife)
    on_knife &= (data.contact.flex[:count] >= 0).any(axis=1)[:, None]
    on_round = data.contact.flex[:count] == sim.dynamometer.round_flex
    times = {}
    for name, load in (("vectorised", contact_load), ("per contact", per_contact_load)):
        start = time.perf_counter()
        for _ in range(repeats):
            for on_object in (on_knife, on_round):
                load(model, data, on_object, np.zeros(3))
        times[name] = (time.perf_counter() - start) / repeats * 1e6
    return {"value": times["vectorised"], "unit": "us/reading (knife and round)",
            "peer": times["per contact"], "peer_name": "one mj_contactForce per contact",
            "ratio": times["vectorised"] / times["per contact"],
            "contacts": int(((on_knife[:, 0] != on_knife[:, 1])
                             | (on_round[:, 0] != on_round[:, 1])).sum())}


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


def run_bench(scenario_path: str | Path, quick: bool = False,
              progress: Progress = None) -> dict[str, Any]:
    """Run every entry on the scenario (``progress`` hears of each as it finishes); returns
    the JSON-ready report."""
    scenario = load_scenario(scenario_path)
    entries = measured({
        "physics_us_per_node_step": lambda: bench_physics(scenario, 50 if quick else 300),
        "ik_ms_per_control_step": lambda: bench_ik(scenario, 50 if quick else 500),
        "episode_real_time_factor": lambda: bench_episode(scenario, quick),
        "trajectory_s": lambda: bench_trajectory(scenario, quick),
        "episode_stepping_share": lambda: bench_profile(scenario, quick),
        "contact_load_us": lambda: bench_contacts(scenario, 200 if quick else 2000),
        "mesh_build_s": lambda: bench_mesh_build(scenario, 2 if quick else 5),
        "episode_growth_exponent": lambda: bench_growth(scenario, quick),
    }, progress)
    return {
        "scenario": str(scenario_path),
        "machine": {"python": platform.python_version(), "processor": platform.machine(),
                    "mujoco": mujoco.__version__, "cpus": usable_cores()},
        "entries": entries,
    }

