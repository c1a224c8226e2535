"""A scripted cutting episode: the camera arm frames the meat, the gripper grasps the shank,
the knife cuts along the interface's top line while the gripper pulls the shank away.

What it measures and its summary: :mod:`cell.sim.summary`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cell.perception.interface import SeenInterface
from cell.perception.pipeline import PerceivedPlan, generic_model, perceive
from cell.profiling import timed
from cell.progress import progress_bar
from cell.robots.camera import CameraRig
from cell.robots.names import CAMERA, GRASP_SITE, KNIFE_BLADE_GEOM, KNIFE_TIP
from cell.sim.assembly import Scene, build_robot_spec, build_scene, grasp_point
from cell.sim.reach import check_plan, check_ready
from cell.sim.relook import Relooks
from cell.sim.scenario import Scenario
from cell.sim.score import CutScore
from cell.sim.simulation import Simulation
from cell.sim.summary import EpisodeTrace, episode_summary, recording_scalars, released_fraction
from cell.tissue.aponeurosis import ReleaseRule
from controllers import gripper, knife
from controllers.camera import view_pose
from controllers.gripper import PullSchedule
from controllers.ik import CellIK, arm_joint_names, pose
from controllers.knife import CutWindow, PassPlan
from controllers.steering import LeanSteering
from controllers.trajectory import CartesianTrajectory

if TYPE_CHECKING:  # Rerun is imported by the recorder only: its import is dear
    from cell.sim.liveview import LiveView
    from cell.sim.recording import EpisodeRecorder

#: IK iterations that bring the arms from home to their ready poses before the episode starts.
_READY_ITERATIONS = 200
#: The site whose drift shows whether an arm that should hold still does.
_HELD_SITES = {"camera": "camera/optical", "gripper": GRASP_SITE, "knife": KNIFE_TIP}
#: Which random stream of the seed the camera's noise draws from (the sensors use stream 0).
_PERCEPTION_STREAM = 1
#: How long before its tool starts work a sensor is tared (the knife before its cut, the
#: gripper and the fixture before the jaws close): the tool still moves steadily then, so the
#: zero holds the tool's weight and not the inertial load of its stop at the work.
TARE_LEAD_S = 0.1


@dataclass(frozen=True)
class EpisodePlan:
    """The tools' plan from their ready poses: what the scripted episode follows.

    Attributes:
        knife: the knife tip's trajectory (world frame, m; times in s of simulated time).
        cut_path_m: (N, 3) planned tip path while cutting, from the entry at depth on, m.
        cut_window_s: when the cut starts and ends, s: the knife is at the entry at depth at
            the start and at the path's last point at the end.
        pull: the grasp site's trajectory.
        schedule: when the gripper closes, grasps and pulls.
        end_s: when the scripted episode stops, s.
        passes: the cut's passes: their windows and when the camera looks between them.

    Example:
        >>> from cell.tissue.geometry import MuscleShape
        >>> plan = Episode(Scenario(tissue=MuscleShape(cell_size_m=0.05))).plan()
        >>> position_m, rotation = plan.knife.sample(plan.cut_window_s.start_s)
        >>> bool(np.allclose(position_m, plan.cut_path_m[0]))  # in at the entry, at depth
        True
    """

    knife: CartesianTrajectory
    cut_path_m: np.ndarray
    cut_window_s: CutWindow
    pull: CartesianTrajectory
    schedule: PullSchedule
    end_s: float
    passes: PassPlan


class Episode:
    """One scripted episode over a freshly built scene.

    Example:
        >>> from dataclasses import replace
        >>> from cell.tissue.geometry import MuscleShape
        >>> scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05), end_s=0.1)
        >>> scenario = replace(scenario, perception=replace(scenario.perception, enabled=False))
        >>> summary = Episode(scenario).run()  # a whole episode: leave end_s out
        >>> summary["result"]["released_fraction"], summary["result"]["sim_time_s"]
        (0.0, 0.1...)
    """

    def __init__(self, scenario: Scenario, scene: Scene | None = None) -> None:
        self.scenario = scenario
        self.arms = scenario.arms.cell_arms()
        self.scene = build_scene(scenario) if scene is None else scene
        self.robot_model = build_robot_spec(
            scenario, handle=self.scene.cad_parts.get("knife.handle_mesh")).compile()
        self.sim = Simulation(self.scene, scenario)
        model = self.scene.model
        names = [n for prefix, arm in self.arms.items() for n in arm_joint_names(prefix, arm)]
        self.scene_qpos = np.array([model.joint(n).qposadr[0] for n in names])
        self.ik_qpos = np.array([self.robot_model.joint(n).qposadr[0] for n in names])
        self.actuators = np.array([model.actuator(n).id for n in names])
        self.fingers = np.array([model.actuator(f"gripper/finger_{s}").id
                                 for s in ("left", "right")])
        self.control_dt_s = 1.0 / scenario.simulation.control_rate_hz
        self.substeps = scenario.simulation.control_substeps
        self.generic = generic_model(scenario.layout.meat_origin_m)
        self.ik = CellIK(self.robot_model, self._home_configuration(), self.arms)
        self._solve_ready_poses()
        check_ready(self.ik, self.arms)
        self._place_arms()
        self._control_steps = 0
        self.step_observers: list[Callable[[], None]] = []  # called after each control step
        self._knife_tared = self._gripper_tared = self._grasped = False
        self._knife_load_n = np.zeros(3)  # the load on the blade at the last reading, world, N
        self._jaw_half_m = np.array([scenario.gripper.finger_width_m / 2,
                                     scenario.gripper.max_opening_m / 2,
                                     scenario.gripper.finger_length_m / 2])

    @property
    def commanded_q_rad(self) -> np.ndarray:
        """The arms' joint commands of the last control step (before the first: the ready
        poses), rad, in the order of :attr:`scene_qpos`."""
        return self._ctrl_prev

    def _home_configuration(self) -> np.ndarray:
        q = self.robot_model.qpos0.copy()
        for prefix, arm in self.arms.items():
            for name, angle in zip(arm_joint_names(prefix, arm), arm.home_q_rad, strict=True):
                q[self.robot_model.joint(name).qposadr[0]] = angle
        return q

    def _solve_ready_poses(self) -> None:
        """Solve IK (kinematics only) for the poses the arms start from: knife above the cut's
        entry, gripper above the grasp point, camera framing the meat."""
        scenario, mesh = self.scenario, self.scene.mesh
        eye, look = view_pose(mesh)
        self.ik.camera.set_target(pose(eye, np.eye(3)))
        self.ik.gaze.set_target(look)
        # Before the camera has looked, the knife can only wait where the generic model
        # puts the valley's end.
        expected = self.generic.top_line if scenario.perception.enabled else mesh.top_line
        self.ik.knife.set_target(pose(*knife.ready_pose(expected, scenario.cut)))
        self.ik.grasp.set_target(pose(*gripper.ready_pose(grasp_point(scenario, mesh),
                                                          scenario.pull)))
        for _ in range(_READY_ITERATIONS):
            self.ik.solve(self.control_dt_s)

    def start_tools_at(self, knife_pose: tuple[np.ndarray, np.ndarray],
                       grasp_pose: tuple[np.ndarray, np.ndarray]) -> None:
        """Start the arms with the knife's tip and the jaws at these poses (position m,
        rotation) instead of the ready poses, before the first control step: where a replayed
        log starts. IK (kinematics only) from the ready poses; the arms placed there."""
        self.ik.knife.set_target(pose(*knife_pose))
        self.ik.grasp.set_target(pose(*grasp_pose))
        for _ in range(_READY_ITERATIONS):
            self.ik.solve(self.control_dt_s)
        self._place_arms()

    def _place_arms(self) -> None:
        data = self.sim.data
        q = self.ik.configuration.q[self.ik_qpos]
        data.qpos[self.scene_qpos] = q
        data.ctrl[self.actuators] = q
        data.ctrl[self.fingers] = self.scenario.gripper.max_opening_m / 2
        self.sim.forward()
        self._ctrl_prev = q.copy()

    def run(self, rerun_path: str | Path | None = None, progress: bool = False,
            view: LiveView | None = None) -> dict[str, Any]:
        """Run the episode; returns the summary. Writes the Rerun file if a path is given, and
        streams the recording to a live ``view`` if one is given.

        Raises:
            DivergenceError: the physics blew up (nothing is written then).
        """
        scenario, model = self.scenario, self.sim.model
        rig = (CameraRig(model, CAMERA, scenario.camera.width_px, scenario.camera.height_px)
               if scenario.perception.enabled or rerun_path or view else nullcontext())
        with rig as camera:
            return self._run(camera, rerun_path, progress, view)

    def _run(self, rig: CameraRig | None, rerun_path: str | Path | None,
             progress: bool, view: LiveView | None = None) -> dict[str, Any]:
        """The episode's loop: long because it is where a control step's parts meet."""
        scenario, sim, ik = self.scenario, self.sim, self.ik
        data, model, scene = sim.data, sim.model, self.scene
        perceived = self.perceive(rig) if rig is not None and scenario.perception.enabled \
            else None
        plan = self.plan(perceived)
        check_plan(self.ik.configuration, self.arms, {"knife": plan.knife, "gripper": plan.pull})
        relooks = None
        if perceived is not None and isinstance(perceived.interface_y, SeenInterface):
            relooks = Relooks(perceived.interface_y, perceived.marker_m, plan.passes.looks_s,
                              scenario.seed)
        steering = (LeanSteering(scenario.steering, perceived.guideline.points_m,
                                 np.asarray(scenario.pull.direction))
                    if perceived is not None else None)
        steps = int(np.ceil(plan.end_s / self.control_dt_s))
        held = {"camera": ik.site_pose("camera/optical")[0]}
        if not scenario.pull.enabled:
            held["gripper"] = ik.site_pose(GRASP_SITE)[0]
        if not scenario.cut.enabled:
            held["knife"] = ik.site_pose(KNIFE_TIP)[0]
        recorder = None
        if rerun_path is not None or view is not None:
            from cell.sim.recording import open_recording
            recorder = open_recording(rerun_path, view, scene,
                                      f"{scenario.name}-{scenario.seed}", plan.cut_path_m,
                                      perceived, plan.passes.cut_paths_m[0])
        frame_every = max(1, round(1.0 / (scenario.recording.rate_hz * self.control_dt_s)))
        camera_every = max(1, round(1.0 / (scenario.recording.camera_rate_hz
                                           * self.control_dt_s)))
        trace = EpisodeTrace()
        tip_site = model.site(KNIFE_TIP).id
        blade = model.geom(KNIFE_BLADE_GEOM).id
        score = CutScore(scene.aponeurosis, scene.mesh, scenario.knife.blade_length_m,
                         scenario.knife.blade_thickness_m)
        wall_start = time.perf_counter()
        try:
            for k in progress_bar("ctrl", quiet=not progress, iterable=range(steps),
                                  desc=scenario.name):
                t_next = (k + 1) * self.control_dt_s
                knife_target = plan.knife.sample(t_next) if scenario.cut.enabled else None
                if knife_target is not None and relooks is not None:
                    knife_target = relooks.correct(knife_target)
                if knife_target is not None and steering is not None:
                    knife_target = steering.correct(knife_target, self._knife_load_n,
                                                    self.control_dt_s)
                grasp_target = plan.pull.sample(t_next) if scenario.pull.enabled else None
                self.control_step(plan, knife_target, grasp_target)
                t = sim.time_s
                tip = data.site_xpos[tip_site]
                self._measure(trace, self._knife_tared, self._gripper_tared)
                for observe in self.step_observers:
                    observe()
                if relooks is not None and relooks.due(t):
                    self._relook(relooks, rig, plan, recorder)
                pass_index = plan.passes.pass_at(t)
                if knife_target is not None and pass_index is not None:
                    trace.tracking_error_m.append(
                        float(np.linalg.norm(tip - knife_target[0])))
                    trace.cutting_force_n.append(trace.knife_force_n[-1])
                    score.observe(data, pass_index, tip, data.geom_xmat[blade].reshape(3, 3)[:, 2])
                    for part, force_n in sim.knife_load_n().items():
                        trace.knife_load_n.setdefault(part, []).append(force_n)
                for name, start in held.items():
                    site = _HELD_SITES[name]
                    drift = float(np.linalg.norm(data.site_xpos[model.site(site).id] - start))
                    trace.held_drift_m[name] = max(trace.held_drift_m.get(name, 0.0), drift)
                if recorder is not None and k % frame_every == 0:
                    recorder.log_frame(data, tip, recording_scalars(
                        trace, released_fraction(scene.aponeurosis)))
                if recorder is not None and rig is not None and k % camera_every == 0:
                    recorder.log_camera(data, rig)
        except BaseException:  # a stop (Ctrl-C, SIGTERM) too: no partial recording stays
            if recorder is not None:
                recorder.abort()
            raise
        wall_s = time.perf_counter() - wall_start
        if recorder is not None:
            recorder.close()
        return episode_summary(scenario, scene, sim, trace, score, plan.passes, wall_s,
                               perceived, relooks, steering)

    @timed("planning")
    def plan(self, perceived: PerceivedPlan | None = None) -> EpisodePlan:
        """Plan the knife and the gripper from the arms' present IK poses (the ready poses
        before the first control step): along the perceived guideline and interface, or the
        generator's own when ``perceived`` is None."""
        scenario, ik, mesh = self.scenario, self.ik, self.scene.mesh
        if perceived is None:
            top, interface_y = mesh.top_line, mesh.interface_y
        else:
            top, interface_y = perceived.guideline.points_m, perceived.interface_y
            if top[0, 0] > top[-1, 0]:  # enter from the end the knife waits at (-x)
                top = top[::-1]
        tip_pos, tip_rot = ik.site_pose(KNIFE_TIP)
        passes = knife.plan_passes(top, scenario.cut, scenario.layout.table_height_m,
                                   scenario.cut.start_s, tip_pos, tip_rot,
                                   interface_y=interface_y)
        knife_traj, cut_path, window = (passes.trajectory, passes.cut_paths_m[-1],
                                        passes.window_s)
        grasp_pos, grasp_rot = ik.site_pose(GRASP_SITE)
        pull_traj, schedule = gripper.plan_pull(
            grasp_point(scenario, mesh), scenario.pull, scenario.settle_s, window,
            grasp_pos, grasp_rot)
        end_s = scenario.end_s or max(knife_traj.end_s, schedule.pull_end_s) + 0.5
        return EpisodePlan(knife_traj, cut_path, window, pull_traj, schedule, end_s, passes)

    @timed("IK and servos")  # the physics and the rules inside it timed as theirs
    def control_step(self, plan: EpisodePlan,
                     knife_target: tuple[np.ndarray, np.ndarray] | None,
                     grasp_target: tuple[np.ndarray, np.ndarray] | None,
                     knife_plan_s: float | None = None,
                     command_q_rad: np.ndarray | None = None,
                     ) -> dict[ReleaseRule, np.ndarray]:
        """One control step: IK toward the tool targets (position m, rotation; None keeps the
        last target), the joint controls ramped over the physics steps, then the plan's
        timed events (sensor tares, closing the jaws, the grasp) and the release rules.
        ``knife_plan_s`` is the plan's time the knife target is at (None: the step's own
        time, for a knife on the plan's clock): whether the knife cuts, and how far into its
        cutting-force curve, follow the knife, so that a knife slower or faster than its
        plan cuts for as long as it is in its cut. ``command_q_rad`` (rad, ordered as
        :attr:`scene_qpos`) replaces the IK: a program played open-loop.

        Returns:
            The bindings released in this step, by rule.

        Raises:
            DivergenceError: the physics blew up.
        """
        scenario, sim, data = self.scenario, self.sim, self.sim.data
        schedule = plan.schedule
        cut_start = plan.cut_window_s.start_s
        self._control_steps += 1
        t_next = self._control_steps * self.control_dt_s
        if knife_target is not None:
            self.ik.knife.set_target(pose(*knife_target))
        if grasp_target is not None:
            self.ik.grasp.set_target(pose(*grasp_target))
        ctrl_next = self.ik.solve(self.control_dt_s)[self.ik_qpos] if command_q_rad is None \
            else np.asarray(command_q_rad, dtype=float)
        if scenario.pull.enabled and t_next >= schedule.close_s:
            data.ctrl[self.fingers] = 0.0
        ctrl_prev = self._ctrl_prev
        for i in range(1, self.substeps + 1):
            data.ctrl[self.actuators] = ctrl_prev + (ctrl_next - ctrl_prev) * (i / self.substeps)
            # One step at a time, the controls ramping between them; the sensors are read
            # after the last.
            sim.step(sensors=i == self.substeps)
        self._ctrl_prev = ctrl_next
        t = sim.time_s
        if not self._knife_tared and t >= cut_start - TARE_LEAD_S:
            sim.tare("knife/force", "knife/torque")
            self._knife_tared = True
        if (scenario.pull.enabled and not self._gripper_tared
                and t >= schedule.close_s - TARE_LEAD_S):
            sim.tare("gripper/force", "gripper/torque", "fixture_force")
            self._gripper_tared = True
        if scenario.pull.enabled and not self._grasped and t >= schedule.grasp_s:
            sim.grasp(self._jaw_half_m)
            self._grasped = True
        knife_s = t if knife_plan_s is None else knife_plan_s
        cutting = plan.passes.pass_at(knife_s) if scenario.cut.enabled else None
        # The measured cutting force runs from each pass's start.
        return sim.apply_release_rules(
            None if cutting is None else knife_s - plan.passes.windows_s[cutting].start_s)

    @timed("perception")
    def perceive(self, rig: CameraRig) -> PerceivedPlan:
        """Look at the meat from the camera arm's pose and plan the cut (paper Sec. 5); the
        sensor noise follows the scenario's seed.

        Raises:
            PerceptionError: no meat in view, no valley at the start marker, a bad fit.
        """
        self.sim.forward()
        rng = np.random.default_rng([self.scenario.seed, _PERCEPTION_STREAM])
        return perceive(rig, self.sim.data, self.scene.mesh, self.generic,
                        self.scenario.perception, rng)

    @timed("perception")
    def _relook(self, relooks: Relooks, rig: CameraRig, plan: EpisodePlan,
                recorder: EpisodeRecorder | None) -> None:
        """The look after a pass: the interface estimate updated, the update and what it
        changes in the next pass's path recorded."""
        self.sim.forward()
        seen = relooks.look(rig, self.sim.data, self.scenario.perception,
                            plan.passes.depths_m[-1])
        if seen is None:
            return
        following = plan.passes.cut_paths_m[len(relooks.updates)]
        shift = relooks.shift_m(following)
        relooks.updates[-1]["next_pass_shift_m"] = {"mean": float(np.abs(shift).mean()),
                                                    "max": float(np.abs(shift).max())}
        if recorder is not None:
            recorder.set_time(self.sim.time_s)
            recorder.log_look(len(relooks.updates), *seen,
                              following + np.outer(shift, [0.0, 1.0, 0.0]))

    def _measure(self, trace: EpisodeTrace, knife_tared: bool, gripper_tared: bool) -> None:
        sim = self.sim
        if knife_tared:
            reading = sim.read_world("knife/force")
            self._knife_load_n = -reading  # the sensor carries the load on the blade: minus
            trace.knife_force_n.append(float(np.linalg.norm(reading)))
            trace.knife_torque_nm.append(float(np.linalg.norm(sim.read("knife/torque"))))
        if gripper_tared:
            trace.pull_force_n.append(float(np.linalg.norm(sim.read("gripper/force"))))
            trace.fixture_force_n.append(float(np.linalg.norm(sim.read("fixture_force"))))
