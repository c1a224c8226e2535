"""Replaying a separation log (docs/logs.md): the tools follow the logged poses of their
sensors through the arms (mink IK and the arms' servos, not the planner), the rest of the
cell is simulated, and every channel is compared with the log per phase (approach, cut,
pull-off) and over time.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from cell.logs.batch import log_scenario
from cell.measure.logs import CHANNELS, Channel, SeparationLog
from cell.progress import progress_bar
from cell.robots.names import GRASP_SITE, KNIFE_TIP
from cell.sim.episode import TARE_LEAD_S, Episode, EpisodePlan
from cell.sim.episodelog import SensorSampler
from cell.sim.scenario import Scenario
from cell.tissue.aponeurosis import ReleaseRule
from controllers.knife import CutWindow

#: The compared channels: name -> (log channel, torque or force): every channel's force, and
#: the torque of those with a pose (:data:`~cell.measure.logs.CHANNELS`).
COMPARED = {f"{stem}_{kind}": (stem, kind == "torque") for stem, pose in CHANNELS.items()
            for kind in (("force", "torque") if pose else ("force",))}
PHASES = ("approach", "cut", "pull_off")
#: The random stream of the seed the replay's sensor noise draws from: not the log's
#: (:data:`~cell.sim.episodelog.LOG_STREAM`), so that a replay of the cell's own log does not
#: reproduce the log's noise draw for draw.
REPLAY_STREAM = 3
#: The share of a tool's pose error (:class:`_ToolTracking`) taken into its target each control
#: step, tuned on logs of the tuning seeds (docs/benchmarks.md): more overshoots the gripper's
#: pull, less leaves the blade's flesh contacts short.
TRACKING_GAIN = 0.6
#: The sensor's own pose: no offset.
_AT_SENSOR = (np.zeros(3), np.eye(3))


@dataclass(frozen=True)
class Replay:
    """A replayed log: the simulated channels and how they compare.

    Attributes:
        log: the log replayed.
        simulated: the simulated channels, sampled at the control steps.
        rmse: per compared channel (:data:`COMPARED`) and phase, the RMSE of the simulated
            vector against the logged one at the logged times (N or N m; None where the log
            has no samples of the phase or no such channel).
        peak: per compared channel, its logged peak (N or N m).
        released: the replay's released bindings by rule and the binding count.
    """

    log: SeparationLog
    simulated: dict[str, Channel]
    rmse: dict[str, dict[str, float | None]]
    peak: dict[str, float]
    released: dict[str, int]

    def summary(self) -> dict[str, Any]:
        """The comparison as JSON-able figures (``rmse_share``: RMSE over the peak)."""
        share = {name: {phase: (None if value is None or not self.peak[name]
                                else value / self.peak[name])
                        for phase, value in phases.items()}
                 for name, phases in self.rmse.items()}
        logged = self.log.outcome
        bindings = max(self.released["bindings"], 1)
        counts = {key: {"logged": logged.get(key), "replayed": self.released[key],
                        "difference_share": (None if key not in logged else
                                             abs(self.released[key] - logged[key]) / bindings)}
                  for key in ("released", "torn")}
        return {"log": self.log.name, "rmse": self.rmse, "peak": self.peak,
                "rmse_share": share, "bindings": self.released["bindings"], "counts": counts}


def _offset(episode: Episode, sensor: str, site: str) -> tuple[np.ndarray, np.ndarray]:
    """The tool's IK site in its sensor's frame: position (m) and rotation (rigid)."""
    data, model = episode.sim.data, episode.sim.model
    s, t = model.sensor(sensor).objid[0], model.site(site).id
    rotation = data.site_xmat[s].reshape(3, 3)
    return (rotation.T @ (data.site_xpos[t] - data.site_xpos[s]),
            rotation.T @ data.site_xmat[t].reshape(3, 3))


def _rotation_matrix(quaternion: np.ndarray) -> np.ndarray:
    """The rotation of ``quaternion`` (w, x, y, z; normalised here)."""
    matrix = np.empty(9)
    mujoco.mju_quat2Mat(matrix, quaternion / np.linalg.norm(quaternion))
    return matrix.reshape(3, 3)


def _rotation_vector(matrix: np.ndarray) -> np.ndarray:
    """The axis times the angle (rad, at most pi) of the rotation ``matrix``."""
    quaternion, vector = np.empty(4), np.empty(3)
    mujoco.mju_mat2Quat(quaternion, matrix.ravel())
    mujoco.mju_quat2Vel(vector, quaternion, 1.0)
    return vector


def _vector_rotation(vector: np.ndarray) -> np.ndarray:
    """The rotation matrix of a rotation vector (axis times angle, rad)."""
    quaternion = np.array([1.0, 0.0, 0.0, 0.0])
    mujoco.mju_quatIntegrate(quaternion, vector, 1.0)
    return _rotation_matrix(quaternion)


def _target(channel: Channel, time_s: float, offset: tuple[np.ndarray, np.ndarray]
            ) -> tuple[np.ndarray, np.ndarray]:
    """The IK site's pose at ``time_s`` from the logged sensor pose (positions interpolated,
    held at the ends; quaternions by the normalised blend of the two samples around it)."""
    t = channel.time_s
    i = int(np.clip(np.searchsorted(t, time_s), 1, len(t) - 1))
    share = float(np.clip((time_s - t[i - 1]) / (t[i] - t[i - 1]), 0.0, 1.0))
    position = (1 - share) * channel.position_m[i - 1] + share * channel.position_m[i]
    a, b = channel.quaternion[i - 1], channel.quaternion[i]
    b = b if np.dot(a, b) >= 0 else -b
    rotation = _rotation_matrix((1 - share) * a + share * b)
    return position + rotation @ offset[0], rotation @ offset[1]


class _ToolTracking:
    """Where a replayed tool is aimed: the logged pose, its sensor's pose error against the
    log integrated from the tool's work on (world frame; a share :data:`TRACKING_GAIN` of
    the error a control step). The arm's servos are compliant, so a tool under the meat's
    load sits off its target; aimed at the logged pose (where the logged tool sat under its
    own load) it would sit off that once more and press the meat less. Before its work a
    tool moves freely and fast: its error there is the servos' lag, which the control step's
    lead takes, and integrating it would only jolt the tool."""

    def __init__(self, episode: Episode, sensor: str, channel: Channel, work_s: float) -> None:
        self.site = int(episode.sim.model.sensor(sensor).objid[0])
        self.channel, self.work_s, self.data = channel, work_s, episode.sim.data
        self.position_m = np.zeros(3)
        self.rotation_rad = np.zeros(3)

    def update(self, time_s: float) -> None:
        """Integrate the sensor's pose error at ``time_s`` (a logged time), once at work."""
        if time_s < self.work_s:
            return
        position, rotation = _target(self.channel, time_s, _AT_SENSOR)
        self.position_m += TRACKING_GAIN * (position - self.data.site_xpos[self.site])
        error = rotation @ self.data.site_xmat[self.site].reshape(3, 3).T
        self.rotation_rad += TRACKING_GAIN * _rotation_vector(error)

    def target(self, time_s: float, offset: tuple[np.ndarray, np.ndarray]
               ) -> tuple[np.ndarray, np.ndarray]:
        """The IK site's target at ``time_s``: the logged pose (:func:`_target`) turned about
        the sensor and moved by the integrated error."""
        sensor, rotation = _target(self.channel, time_s, _AT_SENSOR)
        turn = _vector_rotation(self.rotation_rad) @ rotation
        return sensor + self.position_m + turn @ offset[0], turn @ offset[1]


def _replay_plan(plan: EpisodePlan, log: SeparationLog, control_dt_s: float) -> EpisodePlan:
    """The plan's clock set by the log: the tares, the grasp and the cut windows. The
    episode tares a sensor :data:`~cell.sim.episode.TARE_LEAD_S` before its tool's work (the
    jaws closing, the cut); the replay's events fall on the control step of the logged one,
    half a step early so that rounding cannot put them a step late."""
    grasp = log.channels["gripper"].grasp
    gripper_time = log.channels["gripper"].time_s
    grasp_s = (float(gripper_time[np.argmax(grasp > 0)]) - control_dt_s / 2
               if grasp is not None and grasp.any() else np.inf)
    work = TARE_LEAD_S - control_dt_s / 2
    close_s = (log.sensors["gripper_tare_s"] + work if "gripper_tare_s" in log.sensors
               else grasp_s)
    windows = tuple(CutWindow(a, b) for a, b in log.cut_windows_s) or (CutWindow(np.inf,
                                                                                 np.inf),)
    knife_tare = log.sensors.get("knife_tare_s", float(log.channels["knife"].time_s[0]))
    return replace(plan, schedule=replace(plan.schedule, close_s=close_s, grasp_s=grasp_s),
                   cut_window_s=CutWindow(knife_tare + work, windows[-1].end_s),
                   passes=replace(plan.passes, windows_s=windows))


def replay(log: SeparationLog, scenario: Scenario | None = None,
           progress: bool = False) -> Replay:
    """Replay ``log`` (:mod:`cell.logs.replay`) in its scenario, or in ``scenario`` (a changed
    world: the batch diagnosis); with ``progress``, a bar of the log's seconds on stderr.

    Raises:
        ScenarioError: the log's scenario file is bad.
        DivergenceError: the physics blew up.
    """
    scenario = log_scenario(log) if scenario is None else scenario
    scenario = replace(scenario, perception=replace(scenario.perception, enabled=False))
    episode = Episode(scenario)
    knife, gripper = log.channels["knife"], log.channels["gripper"]
    offsets = (_offset(episode, "knife/force", KNIFE_TIP),
               _offset(episode, "gripper/force", GRASP_SITE))
    # The arms start where the log starts, not at the scenario's ready poses: a start
    # elsewhere would jerk the tools toward the log's first poses.
    episode.start_tools_at(_target(knife, 0.0, offsets[0]), _target(gripper, 0.0, offsets[1]))
    plan = _replay_plan(episode.plan(), log, episode.control_dt_s)
    sampler = SensorSampler(episode.sim, REPLAY_STREAM)
    end_s = float(knife.time_s[-1])
    tracking = (_ToolTracking(episode, "knife/force", knife, plan.cut_window_s.start_s),
                _ToolTracking(episode, "gripper/force", gripper, plan.schedule.close_s))
    with progress_bar("s", quiet=not progress, total=round(end_s, 3),
                      desc=log.folder.name) as bar:
        while episode.sim.time_s < end_s - 1e-9:
            t_next = episode.sim.time_s + episode.control_dt_s
            # The servos reach a target a control step late: aim where the log is a step on.
            lead_s = t_next + episode.control_dt_s
            episode.control_step(plan, tracking[0].target(lead_s, offsets[0]),
                                 tracking[1].target(lead_s, offsets[1]))
            for tool in tracking:
                tool.update(episode.sim.time_s)
            sampler.sample(bool(episode.sim.grasped.size))
            bar.update(episode.control_dt_s)
    simulated = sampler.channels()
    counts = episode.scene.aponeurosis.released_counts()
    released = {"bindings": len(episode.scene.aponeurosis),
                "released": int(sum(counts.values())),
                "torn": int(counts[ReleaseRule.TEARING.value])}
    rmse, peak = compare(log, simulated)
    return Replay(log, simulated, rmse, peak, released)


def _vectors(channel: Channel, torque: bool) -> np.ndarray | None:
    return channel.torque_nm if torque else channel.force_n


def compare(log: SeparationLog, simulated: dict[str, Channel]
            ) -> tuple[dict[str, dict[str, float | None]], dict[str, float]]:
    """Per compared channel and phase, the RMSE of ``simulated`` (interpolated to the logged
    times) against the log; and each logged channel's peak."""
    rmse: dict[str, dict[str, float | None]] = {}
    peak: dict[str, float] = {}
    windows = log.cut_windows_s
    for name, (stem, torque) in COMPARED.items():
        measured, ours = _vectors(log.channels[stem], torque), _vectors(simulated[stem], torque)
        if measured is None or ours is None:
            continue
        t = log.channels[stem].time_s
        at = np.stack([np.interp(t, simulated[stem].time_s, ours[:, k]) for k in range(3)],
                      axis=1)
        error = np.linalg.norm(at - measured, axis=1)
        start, end = (windows[0][0], windows[-1][1]) if windows else (np.inf, np.inf)
        masks = {"approach": t < start, "cut": (t >= start) & (t <= end), "pull_off": t > end}
        rmse[name] = {phase: (float(np.sqrt(np.mean(error[mask] ** 2))) if mask.any()
                              else None) for phase, mask in masks.items()}
        peak[name] = float(np.linalg.norm(measured, axis=1).max())
    return rmse, peak


def write_replay(folder: str | Path, result: Replay) -> Path:
    """``replay.json`` (:meth:`Replay.summary`) and, per channel, ``<channel>.csv``: the
    logged and the simulated force (and torque) side by side at the logged times."""
    from cell.outputs import write_json, write_rows

    folder = Path(folder)
    for stem, logged in result.log.channels.items():
        ours = result.simulated[stem]
        columns = ["time_s"]
        rows: list[dict[str, float]] = [{"time_s": float(t)} for t in logged.time_s]
        for kind in ("force", "torque"):
            measured, simulated = _vectors(logged, kind == "torque"), _vectors(
                ours, kind == "torque")
            if measured is None or simulated is None:
                continue
            unit = "N" if kind == "force" else "Nm"
            for k, axis in enumerate("xyz"):
                at = np.interp(logged.time_s, ours.time_s, simulated[:, k])
                names = (f"logged_{kind}_{axis}_{unit}", f"simulated_{kind}_{axis}_{unit}")
                columns += names
                for row, a, b in zip(rows, measured[:, k], at, strict=True):
                    row[names[0]], row[names[1]] = float(a), float(b)
        write_rows(folder / f"{stem}.csv", columns, rows)
    write_json(folder / "replay.json", result.summary())
    return folder
