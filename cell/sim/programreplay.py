"""A robot program played open-loop: the joint commands an episode sent at each control step
(its program, as ``musclecell run --trajectory`` writes it), sent to the arms' servos in a
fresh episode of the same scenario and seed, with no IK, no steering and no re-look: what the
arms do when a controller runs the file. The tool path it gives is the file's own when the
file holds the program whole (docs/robot-programs.md).
"""

from __future__ import annotations

import numpy as np

from cell.errors import ScenarioError
from cell.robots.camera import CameraRig
from cell.robots.names import CAMERA
from cell.sim.episode import Episode
from cell.sim.scenario import Scenario
from cell.sim.trajectory import EpisodeTrajectory, TrajectorySampler
from controllers.ik import arm_joint_names


def play_program(scenario: Scenario, commands_q_rad: dict[str, np.ndarray]
                 ) -> EpisodeTrajectory:
    """``scenario``'s cell driven by ``commands_q_rad`` (joint name -> (n,) commands, rad, one
    a control step, every arm joint of the cell), sampled as ``run --trajectory`` samples an
    episode: its :class:`~cell.sim.trajectory.EpisodeTrajectory`.

    Raises:
        ScenarioError: a joint of the cell without commands, or commands of unequal length.
        DivergenceError: the physics blew up.

    Example:
        >>> from dataclasses import replace
        >>> from cell.sim.scenario import Scenario
        >>> from cell.tissue.geometry import MuscleShape
        >>> scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05), end_s=0.05)
        >>> scenario = replace(scenario, perception=replace(scenario.perception, enabled=False))
        >>> episode = Episode(scenario)
        >>> sampler = TrajectorySampler.attach(episode)
        >>> _ = episode.run()
        >>> ran = sampler.trajectory()
        >>> commands = {name: arm.planned_q_rad[:, k] for arm in ran.arms.values()
        ...             for k, name in enumerate(arm.joints)}
        >>> played = play_program(scenario, commands)
        >>> float(np.abs(played.arms["knife_arm"].tool_position_m
        ...              - ran.arms["knife_arm"].tool_position_m).max())
        0.0
    """
    episode = Episode(scenario)
    joints = [name for prefix, arm in episode.arms.items()
              for name in arm_joint_names(prefix, arm)]
    missing = [name for name in joints if name not in commands_q_rad]
    if missing:
        raise ScenarioError(None, "program", f"no commands for the joints {missing}")
    steps = {len(commands_q_rad[name]) for name in joints}
    if len(steps) != 1:
        raise ScenarioError(None, "program", f"joints with {sorted(steps)} commands: one "
                            "count for every joint")
    commands = np.column_stack([np.asarray(commands_q_rad[name], dtype=float)
                                for name in joints])
    perceived = None
    if scenario.perception.enabled:  # the plan's timing (grasp, cut windows) as the run's
        with CameraRig(episode.sim.model, CAMERA, scenario.camera.width_px,
                       scenario.camera.height_px) as rig:
            perceived = episode.perceive(rig)
    plan = episode.plan(perceived)
    sampler = TrajectorySampler(episode)
    for command in commands:
        episode.control_step(plan, None, None, command_q_rad=command)
        sampler.sample()
    return sampler.trajectory()
