"""Where an episode's wall time goes (``musclecell run --profile``, ``bench cell``): the
parts of :data:`EPISODE_PARTS` (:mod:`cell.profiling`), from the process's start to the
summary, with MuJoCo's own timers of its step.

MuJoCo 4 fills ``mjData.timer`` in every ``mj_step`` (its own monotonic clock, s; no flag to
set and no ``mjcb_time`` callback needed); :func:`mujoco_stages` reads the stages of the
step from them. They count the few ``mj_forward`` calls outside the steps too (the camera's
looks, the arms placed), a handful against thousands of steps.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager

import mujoco

from cell.profiling import Profile, part, process_start_s
from cell.sim.assembly import build_scene
from cell.sim.episode import Episode
from cell.sim.scenario import Scenario

#: The start: the interpreter and the imports, up to the profile's start in the command.
IMPORTS = "start-up: Python and imports"
#: The part that MuJoCo's stages split.
MUJOCO_STEP = "MuJoCo step"
#: An episode's parts, in the order the table lists them: the start (command to the first
#: step but the camera's first look), then the control loop's parts, then the summary.
EPISODE_PARTS = (
    IMPORTS, "start-up: scene", "start-up: arms and simulation",
    "perception", "planning", "IK and servos", "tissue law", "implicit solve", "bindings",
    "cutting terms", MUJOCO_STEP, "divergence check", "release rules", "sensing", "scoring",
    "recording", "summary")
_TIMER = mujoco.mjtTimer
#: MuJoCo's stages of a step by the name the table gives them (its collision has broad and
#: narrow phases inside; the constraint stage is the solve, ``make`` sets it up).
MUJOCO_TIMERS = {
    "kinematics": _TIMER.mjTIMER_POS_KINEMATICS,
    "inertia": _TIMER.mjTIMER_POS_INERTIA,
    "collision": _TIMER.mjTIMER_POS_COLLISION,
    "constraint make and project": (_TIMER.mjTIMER_POS_MAKE, _TIMER.mjTIMER_POS_PROJECT),
    "velocity": _TIMER.mjTIMER_VELOCITY,
    "actuation": _TIMER.mjTIMER_ACTUATION,
    "constraint solve": _TIMER.mjTIMER_CONSTRAINT,
    "integration": _TIMER.mjTIMER_ADVANCE,
}


def start_episode(scenario: Scenario, kind: type[Episode] = Episode) -> Episode:
    """An episode of ``kind`` on ``scenario``, its scene's build and the rest of its start
    timed as the two start-up parts."""
    with part("start-up: scene"):
        scene = build_scene(scenario)
    with part("start-up: arms and simulation"):
        return kind(scenario, scene)


def mujoco_stages(data: mujoco.MjData) -> dict[str, float]:
    """Time in each stage of MuJoCo's steps since ``data`` was made, s (MuJoCo's timers);
    ``other`` is the rest of its step (sensors, energy, checks)."""
    def seconds(timers: mujoco.mjtTimer | tuple[mujoco.mjtTimer, ...]) -> float:
        timers = timers if isinstance(timers, tuple) else (timers,)
        return sum(float(data.timer[timer].duration) for timer in timers)

    stages = {name: seconds(timers) for name, timers in MUJOCO_TIMERS.items()}
    stages["other"] = seconds(_TIMER.mjTIMER_STEP) - sum(stages.values())
    return stages


@contextmanager
def episode_profile(enabled: bool) -> Iterator[Profile | None]:
    """A profile of the episode's parts, on inside the block (None and nothing timed when
    not ``enabled``); the time from the process's start to the block is its start-up."""
    if not enabled:
        yield None
        return
    profile = Profile(EPISODE_PARTS, started_s=process_start_s())
    profile.add(IMPORTS, time.perf_counter() - profile.started_s)
    with profile.on():
        yield profile
    profile.stop()


def add_mujoco_stages(profile: Profile, data: mujoco.MjData) -> None:
    """Split the profile's MuJoCo step by MuJoCo's timers in ``data``."""
    profile.details[MUJOCO_STEP] = mujoco_stages(data)
