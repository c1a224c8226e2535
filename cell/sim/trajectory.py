"""The robot program an episode ran: per arm, its planned and its executed joint trajectory at
the control rate, its tool's pose, and the knife's and the gripper's wrench, sampled as the
episode runs (:class:`TrajectorySampler`). What ``musclecell run --trajectory`` writes
(:mod:`cell.sim.trajectoryfiles`) and checks against the arms' limits
(:mod:`cell.sim.trajectorylimits`).

The plan is the joint commands the controller sent (the IK solution toward the tools' targets,
step by step); its velocities are their differences over a control step. The execution is the
joints' state after the step's physics; the tool poses are those the executed joint positions
give (forward kinematics). The wrench is the sensor's own reading (tared when the
episode tares it, with its bias and noise drawn from a stream of the seed of its own, so that
an episode with a trajectory gives the same result as one without).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import mujoco
import numpy as np

from cell.robots.names import GRASP_SITE, KNIFE_TIP
from cell.sim.episode import Episode
from controllers.ik import arm_joint_names

#: Which random stream of the seed the wrench's sensor noise draws from (the sensors use 0,
#: the camera 1, a log 2, a replay 3).
TRAJECTORY_STREAM = 4
#: The site each arm's tool pose is given at.
TOOL_SITES = {"knife_arm": KNIFE_TIP, "pull_arm": GRASP_SITE, "camera_arm": "camera/optical"}
#: The force/torque sensors whose wrench is written: the knife's and the gripper's.
WRENCH_SENSORS = ("knife", "gripper")


@dataclass(frozen=True, eq=False)
class ArmTrajectory:
    """One arm's joint trajectory over the episode, one row per control step.

    Attributes:
        joints: the joints' names in the scene (``knife_arm/joint1``, ...).
        planned_q_rad, planned_qd_rad_s: (n, dof) the commands sent and their velocities.
        executed_q_rad, executed_qd_rad_s: (n, dof) the joints' positions and velocities.
        effort_nm: (n, dof) the joints' actuator torques, N m.
        max_speed_rad_s: (dof,) the arm's rated joint speeds.
        tool_site: the site its tool pose is given at.
        tool_position_m: (n, 3) the tool site's position, world frame.
        tool_quaternion: (n, 4) its orientation (w, x, y, z; w >= 0), world frame.
        max_accel_rad_s2: (dof,) the arm's rated joint accelerations, or None where its
            scenario rates none.

    Example:
        >>> arm = ArmTrajectory(("a/joint1",), *[np.zeros((2, 1))] * 5, np.ones(1), "a/tip",
        ...                     np.zeros((2, 3)), np.tile([1.0, 0, 0, 0], (2, 1)))
        >>> arm.dof
        1
    """

    joints: tuple[str, ...]
    planned_q_rad: np.ndarray
    planned_qd_rad_s: np.ndarray
    executed_q_rad: np.ndarray
    executed_qd_rad_s: np.ndarray
    effort_nm: np.ndarray
    max_speed_rad_s: np.ndarray
    tool_site: str
    tool_position_m: np.ndarray
    tool_quaternion: np.ndarray
    max_accel_rad_s2: np.ndarray | None = None

    @property
    def dof(self) -> int:
        """Number of joints."""
        return len(self.joints)


@dataclass(frozen=True, eq=False)
class EpisodeTrajectory:
    """What an episode's arms were told and did, at the control rate.

    Attributes:
        time_s: (n,) each control step's end, s of simulated time.
        control_dt_s: the control step, s.
        start_q_rad: per arm, (dof,) the commands before the first step (the ready pose).
        arms: per arm prefix (``knife_arm``, ``pull_arm``, ``camera_arm``), its trajectory.
        wrench_frames: per sensor (``knife``, ``gripper``), the site its wrench is given in.
        force_n, torque_nm: per sensor, (n, 3) its reading in its site's frame.

    Example:
        >>> trajectory = EpisodeTrajectory(np.array([0.02]), 0.02, {}, {}, {}, {}, {})
        >>> trajectory.steps
        1
    """

    time_s: np.ndarray
    control_dt_s: float
    start_q_rad: dict[str, np.ndarray]
    arms: dict[str, ArmTrajectory]
    wrench_frames: dict[str, str]
    force_n: dict[str, np.ndarray]
    torque_nm: dict[str, np.ndarray]

    @property
    def steps(self) -> int:
        """Number of control steps."""
        return len(self.time_s)


def _rated(limits: tuple[float, ...] | None) -> np.ndarray | None:
    return None if limits is None else np.array(limits)


class TrajectorySampler:
    """Samples an episode's arms and tool sensors after every control step: register it with
    :meth:`attach`, run the episode, then take :meth:`trajectory`. :attr:`elapsed_s` is the
    wall time the sampling took during the episode, s.

    Example:
        >>> from dataclasses import replace
        >>> from cell.sim.scenario import Scenario
        >>> from cell.tissue.geometry import MuscleShape
        >>> scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05), end_s=0.1)
        >>> scenario = replace(scenario, perception=replace(scenario.perception, enabled=False))
        >>> episode = Episode(scenario)
        >>> sampler = TrajectorySampler.attach(episode)
        >>> _ = episode.run()
        >>> sampler.trajectory().arms["knife_arm"].executed_q_rad.shape
        (5, 6)
    """

    def __init__(self, episode: Episode) -> None:
        self.episode = episode
        model = episode.sim.model
        self.rng = np.random.default_rng([episode.scenario.seed, TRAJECTORY_STREAM])
        self.joints = {prefix: tuple(arm_joint_names(prefix, arm))
                       for prefix, arm in episode.arms.items()}
        names = [name for joints in self.joints.values() for name in joints]
        self._dofs = np.array([model.joint(name).dofadr[0] for name in names])
        self._start_q = episode.commanded_q_rad.copy()
        self._rows: list[np.ndarray] = []
        self.elapsed_s = 0.0

    @classmethod
    def attach(cls, episode: Episode) -> TrajectorySampler:
        """A sampler of ``episode``, called after each of its control steps."""
        sampler = cls(episode)
        episode.step_observers.append(sampler.sample)
        return sampler

    def sample(self) -> None:
        """One row: the step's time, commands, joint states and wrenches."""
        start = time.perf_counter()
        episode, sim = self.episode, self.episode.sim
        data = sim.data
        wrenches = [sim.read(f"{sensor}/{kind}", self.rng)
                    for sensor in WRENCH_SENSORS for kind in ("force", "torque")]
        self._rows.append(np.concatenate([
            [sim.time_s], episode.commanded_q_rad, data.qpos[episode.scene_qpos],
            data.qvel[self._dofs], data.actuator_force[episode.actuators], *wrenches]))
        self.elapsed_s += time.perf_counter() - start

    def _tool_poses(self, executed_q: np.ndarray) -> np.ndarray:
        """(n, 7 per tool) each tool site's position and quaternion at the executed joint
        positions (forward kinematics: after a step MuJoCo's site poses are those before
        its last integration, the joints' positions after it)."""
        # The arms and tools alone (the IK's model: the scene's kinematics, without the meat).
        model = self.episode.robot_model
        data = mujoco.MjData(model)
        sites = [model.site(name).id for name in TOOL_SITES.values()]
        poses = np.empty((len(executed_q), 7 * len(sites)))
        quaternion = np.zeros(4)
        for k, q in enumerate(executed_q):
            data.qpos[self.episode.ik_qpos] = q
            mujoco.mj_kinematics(model, data)
            for n, site in enumerate(sites):
                mujoco.mju_mat2Quat(quaternion, data.site_xmat[site])
                quaternion *= np.sign(quaternion[0]) or 1.0  # one of the two: w >= 0
                poses[k, 7 * n:7 * n + 7] = np.concatenate([data.site_xpos[site], quaternion])
        return poses

    def trajectory(self) -> EpisodeTrajectory:
        """The samples so far."""
        n_q = len(self._start_q)
        table = np.array(self._rows).reshape(len(self._rows), -1)
        time_s, rest = table[:, 0], table[:, 1:]
        planned, executed, speed, effort = (rest[:, k * n_q:(k + 1) * n_q] for k in range(4))
        dt = self.episode.control_dt_s
        planned_qd = np.diff(np.vstack([self._start_q, planned]), axis=0) / dt
        poses = self._tool_poses(executed)
        wrenches = rest[:, 4 * n_q:]
        arms, start_q, column = {}, {}, 0
        for k, (prefix, joints) in enumerate(self.joints.items()):
            cols = slice(column, column + len(joints))
            column += len(joints)
            start_q[prefix] = self._start_q[cols]
            arms[prefix] = ArmTrajectory(
                joints, planned[:, cols], planned_qd[:, cols], executed[:, cols],
                speed[:, cols], effort[:, cols],
                np.array(self.episode.arms[prefix].max_speed_rad_s),
                TOOL_SITES[prefix], poses[:, 7 * k:7 * k + 3], poses[:, 7 * k + 3:7 * k + 7],
                _rated(self.episode.arms[prefix].max_accel_rad_s2))
        model = self.episode.sim.model
        frames = {sensor: model.site(int(model.sensor(f"{sensor}/force").objid[0])).name
                  for sensor in WRENCH_SENSORS}
        force = {sensor: wrenches[:, 6 * k:6 * k + 3] for k, sensor in enumerate(WRENCH_SENSORS)}
        torque = {sensor: wrenches[:, 6 * k + 3:6 * k + 6]
                  for k, sensor in enumerate(WRENCH_SENSORS)}
        return EpisodeTrajectory(time_s, dt, start_q, arms, frames, force, torque)
