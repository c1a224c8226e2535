"""The command-line side of the simulation: ``musclecell run``, ``plan``, ``export-mjcf`` and
``render``.

Light at import (the parser is built for every command): the handlers import the rest. Each
handler checks its outputs (:mod:`cell.outputs`) before it builds anything.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from cell.errors import InputError, ScenarioError
from cell.options import add_out, add_quiet, moved_positional
from cell.outputs import Output, check_outputs

if TYPE_CHECKING:
    from cell.sim.episode import Episode
    from cell.sim.scenario import Scenario
    from cell.sim.trajectory import TrajectorySampler


def add_simulation(commands: argparse._SubParsersAction) -> None:
    """The ``run``, ``plan``, ``export-mjcf`` and ``render`` subcommands."""
    run = commands.add_parser("run", help="run a scripted cutting episode")
    run.add_argument("scenario", type=Path, metavar="SCENARIO", help="scenario TOML file")
    run.add_argument("--rerun", type=Path, metavar="FILE",
                     help="write a Rerun recording (.rrd) here")
    add_out(run, "write the summary JSON here", old=("--summary",))
    run.add_argument("--seed", type=int, help="override the scenario's seed")
    run.add_argument("--log", type=Path, metavar="DIR", help="write the episode's separation "
                     "log (sensors over time, docs/logs.md) into this folder")
    run.add_argument("--trajectory", type=Path, metavar="FILE",
                     help="write the arms' planned and executed joint trajectories, tool poses "
                     "and wrenches here: .mcap (ROS 2 messages) or .csv; and their limits "
                     "report beside it (FILE's stem + .limits.json)")
    run.add_argument("--view", nargs="?", const="auto", choices=("auto", "spawn", "serve"),
                     help="show the recording live in Rerun's viewer as the episode runs: "
                     "spawn the viewer (a display), serve it to a browser (none), or auto "
                     "(the default of a bare --view: spawn where there is a display)")
    run.add_argument("--grpc-port", type=int, default=9876,
                     help="--view: the port the recording streams on (default 9876)")
    run.add_argument("--web-port", type=int, default=9090,
                     help="--view serve: the web viewer's port (default 9090)")
    run.add_argument("--view-hold", type=float, metavar="S",
                     help="--view serve: keep serving S seconds after the episode (default: "
                     "until Ctrl-C)")
    run.add_argument("--profile", action="store_true",
                     help="print where the wall time goes, by part (docs/cli.md), and add "
                     "it to the summary JSON as 'profile'")
    add_quiet(run)
    run.set_defaults(handler=run_command)

    plan = commands.add_parser(
        "plan", help="perceive the cut and plan the knife at the ready poses (no physics)")
    plan.add_argument("scenario", type=Path, metavar="SCENARIO", help="scenario TOML file")
    add_out(plan, "write the plan's figures (JSON) here", required=True, old=("--json",))
    plan.add_argument("--seed", type=int, help="override the scenario's seed (sensor noise)")
    plan.set_defaults(handler=plan_command)

    export = commands.add_parser("export-mjcf", help="write the scene as MJCF",
                                 usage="%(prog)s [-h] SCENARIO -o FILE")
    export.add_argument("scenario", type=Path, metavar="SCENARIO", help="scenario TOML file")
    export.add_argument("output", type=Path, nargs="?", metavar="OUTPUT",
                        help="deprecated: the old place of --out")
    add_out(export, "write the MJCF here (required; the deprecated positional OUTPUT in "
            "its place is accepted, with a warning)")
    export.set_defaults(handler=export_command)

    render = commands.add_parser(
        "render", help="draw the scenario's cell at its start (arms at their ready poses) "
        "as a PNG picture")
    render.add_argument("scenario", type=Path, metavar="SCENARIO", help="scenario TOML file")
    add_out(render, "write the PNG picture here", required=True, old=("--png",))
    render.add_argument("--width", type=int, default=1280, help="px (default 1280)")
    render.add_argument("--height", type=int, default=720, help="px (default 720)")
    render.add_argument("--camera", help="a camera of the model (e.g. camera/camera: what the "
                        "cell's camera sees); default: a free view of the whole cell")
    render.set_defaults(handler=render_command)


def load(args: argparse.Namespace) -> Scenario:
    """The scenario named on the command line, with ``--seed`` applied when the command
    has one."""
    from cell.sim.scenario import load_scenario

    scenario = load_scenario(args.scenario)
    seed = getattr(args, "seed", None)
    if seed is not None:
        if seed < 0:
            raise ScenarioError(None, "--seed", f"must be >= 0, got {seed}")
        scenario = replace(scenario, seed=seed)
    return scenario


def run_command(args: argparse.Namespace) -> int:
    """``musclecell run``."""
    from cell.folders import write_folder
    from cell.outputs import write_json
    from cell.sim.episode import Episode
    from cell.sim.episodelog import LoggedEpisode, write_log
    from cell.sim.profiled import add_mujoco_stages, episode_profile, start_episode
    from cell.sim.trajectory import TrajectorySampler
    from cell.sim.trajectoryfiles import check_trajectory_path, limits_path

    if args.trajectory:
        check_trajectory_path(args.trajectory)
    check_outputs([args.rerun and Output(args.rerun, "--rerun"),
                   args.out and Output(args.out, "--out"),
                   args.trajectory and Output(args.trajectory, "--trajectory"),
                   args.trajectory and Output(limits_path(args.trajectory), "--trajectory"),
                   args.log and Output(args.log, "--log", folder=True, whole=True,
                                       marks=("log.toml",))],
                  [args.scenario])
    view = None
    if args.view:
        from cell.sim.liveview import LiveView  # Rerun loads only when a view is asked for

        view = LiveView(args.view, args.grpc_port, args.web_port, args.view_hold)
    with episode_profile(args.profile) as profile:
        episode = start_episode(load(args), LoggedEpisode if args.log else Episode)
        sampler = TrajectorySampler.attach(episode) if args.trajectory else None
        start = time.perf_counter()
        summary = episode.run(rerun_path=args.rerun, progress=not args.quiet, view=view)
    if sampler is not None:
        _write_trajectory(args.trajectory, episode, sampler, time.perf_counter() - start)
    if profile is not None:
        add_mujoco_stages(profile, episode.sim.data)
        summary["profile"] = profile.to_dict()
    if args.out:
        write_json(args.out, summary)
    if isinstance(episode, LoggedEpisode):
        write_folder(args.log, lambda folder: write_log(folder, episode, args.scenario))
    result = summary["result"]
    print(f"released {result['released_fraction']:.1%} of {result['bindings']} bindings "
          f"{result['released_by_rule']}, median gap {result['gap_m']['median'] * 1e3:.1f} mm, "
          f"knife tracking median {result['knife_tracking_error_m']['median'] * 1e3:.2f} mm, "
          f"real-time factor {summary['timing']['real_time_factor']:.3f}")
    if profile is not None:
        print(profile.table())
    return 0


def _write_trajectory(path: Path, episode: Episode, sampler: TrajectorySampler,
                      episode_wall_s: float) -> None:
    """The trajectory file and its limits report; what writing them cost (the sampling
    during the episode, the report and the files) against the episode's wall time (its run:
    perception, plan and control loop)."""
    from cell.sim.trajectoryfiles import program_output, write_trajectory

    start = time.perf_counter()
    output = program_output(episode, sampler, path.suffix)
    write_trajectory(path, output)
    cost_s = sampler.elapsed_s + time.perf_counter() - start
    report = output.report
    verdict = ("the limits hold" if report["holds"]
               else f"{len(report['flags'])} limits broken: {'; '.join(report['flags'])}")
    print(f"wrote {path} ({output.trajectory.steps} control steps; {verdict}); the trajectory "
          f"took {cost_s / episode_wall_s:.1%} of the episode's wall time")


def plan_command(args: argparse.Namespace) -> int:
    """``musclecell plan``: what the episode would see with this seed, and where the knife
    would go."""
    import numpy as np

    from cell.outputs import write_json
    from cell.robots.camera import CameraRig
    from cell.robots.names import CAMERA, KNIFE_TIP
    from cell.sim.episode import Episode
    from controllers.knife import plan_cut

    check_outputs([Output(args.out, "--out")], [args.scenario])
    scenario = load(args)
    episode = Episode(scenario)
    truth = episode.scene.mesh
    with CameraRig(episode.scene.model, CAMERA, scenario.camera.width_px,
                   scenario.camera.height_px) as rig:
        plan = episode.perceive(rig)
    tip_m, tip_rotation = episode.ik.site_pose(KNIFE_TIP)
    _, tip_path, window_s = plan_cut(
        plan.guideline.points_m, scenario.cut, scenario.layout.table_height_m,
        scenario.cut.start_s, tip_m, tip_rotation, interface_y=plan.interface_y)
    # How far the planned blade tip is from the true interface: what the cut would part.
    offset = np.abs(tip_path[:, 1] - truth.interface_y(tip_path[:, 0], tip_path[:, 2]))
    summary = {"scenario": scenario.name, "seed": scenario.seed, **plan.summary(),
               "knife": {"cut_window_s": list(window_s), "tip_points": len(tip_path),
                         "tip_offset_from_true_interface_m": {"mean": float(offset.mean()),
                                                              "max": float(offset.max())}}}
    write_json(args.out, summary)
    distance = plan.guideline_distance_m
    depth = plan.cut_depth_m
    print(f"guideline {plan.guideline.length_m:.3f} m, {len(plan.guideline.nodes)} nodes, "
          f"{distance.mean_m * 1e3:.1f} mm mean / {distance.max_m * 1e3:.1f} mm max from the "
          f"true top line; fit rms {plan.fit.rms_m * 1e3:.2f} mm; cut depth "
          f"{depth.min() * 1e3:.0f}-{depth.max() * 1e3:.0f} mm; knife tip "
          f"{offset.mean() * 1e3:.1f} mm mean from the true interface; perception "
          f"{plan.timings_s['total']:.2f} s; wrote {args.out}")
    return 0


def export_command(args: argparse.Namespace) -> int:
    """``musclecell export-mjcf``."""
    from cell.sim.assembly import build_scene, export_mjcf

    out = moved_positional(args.output, args.out, "OUTPUT")
    if out is None:
        raise InputError(None, "--out", "missing: export-mjcf SCENARIO --out FILE.xml")
    check_outputs([Output(out, "--out" if args.output is None else "OUTPUT")], [args.scenario])
    path = export_mjcf(build_scene(load(args)), out)
    print(f"wrote {path}")
    return 0


def render_command(args: argparse.Namespace) -> int:
    """``musclecell render``: the cell as the episode starts it, arms at their ready poses."""
    from cell.outputs import write_atomic
    from cell.sim.episode import Episode
    from cell.sim.picture import check_size, png_bytes, render_rgb

    check_size(args.width, args.height)
    check_outputs([Output(args.out, "--out")], [args.scenario])
    episode = Episode(load(args))
    rgb = render_rgb(episode.sim.model, episode.sim.data, args.width, args.height,
                     args.camera)
    write_atomic(args.out, png_bytes(rgb))
    print(f"wrote {args.out} ({args.width} x {args.height} px)")
    return 0
