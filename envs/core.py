"""The separation task's mechanics behind the Gymnasium API: the constructor's checks, the
cell built and its approach played, one control step of an action, the episode's bookkeeping.

:class:`envs.separation.MuscleSeparationEnv` (and its tasks :class:`envs.tasks.CutEnv`,
:class:`envs.tasks.PullEnv`) is the env to use; its docstring is the manual.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any, ClassVar, Literal

import gymnasium as gym
import numpy as np

from cell.errors import DivergenceError, InputError
from cell.memory import return_freed_memory
from cell.robots.camera import CameraRig
from cell.robots.names import CAMERA
from cell.sim.assembly import grasp_point
from cell.sim.episode import Episode, EpisodePlan
from cell.sim.scenario import Scenario
from cell.tissue.aponeurosis import ReleaseRule
from envs.commands import KnifeCommand, Pose, PullCommand
from envs.observation import OBSERVATION_BOUND, OBSERVATION_NAMES, Sensing, observe
from envs.options import apply_options, knife_pace, merge_options
from envs.params import ActionLimits, RewardParams, TaskParams
from envs.randomization import Randomization, check_ranges, load_randomization
from envs.render import RENDER_MODES, CellRenderer, CellWindow, check_render
from envs.reward import reward_terms
from envs.settings import TIME_MARGIN_S, parameters, task_scenario

Driven = Literal["both", "knife", "pull"]
#: Action entries of the knife (along speed, across, depth, yaw) and of the pull (x, y, z).
KNIFE_DIMS = 4
PULL_DIMS = 3


class SeparationCore(gym.Env[np.ndarray, np.ndarray]):
    """The mechanics of :class:`envs.separation.MuscleSeparationEnv` (its arguments, its
    manual); ``reset`` is the env's.

    Example:
        >>> from envs.separation import MuscleSeparationEnv
        >>> issubclass(MuscleSeparationEnv, SeparationCore)
        True
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": list(RENDER_MODES), "render_fps": 50}

    def __init__(self, scenario: Scenario | None = None,
                 cell_size_m: float | None = None, perception: bool = False,
                 options: Mapping[str, Any] | None = None,
                 limits: ActionLimits | Mapping[str, Any] | None = None,
                 reward: RewardParams | Mapping[str, Any] | None = None,
                 time_limit_s: float | None = None, driven: Driven = "both",
                 render_mode: str | None = None, randomize: bool = True,
                 randomization: str | Path | Randomization | None = None,
                 task: TaskParams | Mapping[str, Any] | None = None,
                 timeout_terminates: bool = False, width: int = 320, height: int = 240
                 ) -> None:
        if driven not in ("both", "knife", "pull"):
            raise InputError(None, "driven", f"must be both, knife or pull, got {driven!r}")
        check_render(render_mode, width, height)
        if time_limit_s is not None and not time_limit_s > 0:
            raise InputError(None, "time_limit_s", f"must be > 0, got {time_limit_s}")
        if not isinstance(timeout_terminates, bool):
            raise InputError(None, "timeout_terminates", f"expected true or false, got "
                             f"{timeout_terminates!r}")
        if scenario is None:
            scenario = task_scenario()
        if cell_size_m is not None:
            scenario = replace(scenario, tissue=replace(scenario.tissue, cell_size_m=cell_size_m))
        self.base = replace(scenario, perception=replace(scenario.perception,
                                                         enabled=perception))
        self.options = merge_options(options or {})  # an old option's name, renamed once
        apply_options(self.base, self.options)  # fail now, not at the first reset
        self.randomize = randomize
        # Ranges are checked on this env's cell where it draws (a continuum material, say,
        # has no fibres to turn), on the default cell otherwise.
        checked_on = self.base if randomize else Scenario()
        if isinstance(randomization, Randomization):
            check_ranges(randomization, checked_on)
        else:
            randomization = load_randomization(randomization, checked_on)
        self.randomization = randomization
        self.limits = parameters(ActionLimits, limits, "limits")
        self.reward_params = parameters(RewardParams, reward, "reward")
        self.task = parameters(TaskParams, task, "task")
        self.time_limit_s = time_limit_s
        self.timeout_terminates = timeout_terminates
        self.driven = driven
        self.render_mode = render_mode
        self.width, self.height = width, height
        self._drives_knife = driven in ("both", "knife")
        self._drives_pull = driven in ("both", "pull")
        dims = KNIFE_DIMS * self._drives_knife + PULL_DIMS * self._drives_pull
        self.action_space = gym.spaces.Box(-1.0, 1.0, (dims,), np.float32)
        self.observation_names: tuple[str, ...] = OBSERVATION_NAMES
        self.observation_space = gym.spaces.Box(-OBSERVATION_BOUND, OBSERVATION_BOUND,
                                                (len(OBSERVATION_NAMES),), np.float32)
        self.episode: Episode | None = None
        self.plan: EpisodePlan | None = None
        self.world: dict[str, Any] = {}
        self.redraws: list[str] = []
        self._renderer: CellRenderer | CellWindow | None = None

    def _start(self, scenario: Scenario) -> None:
        """Build the cell of ``scenario``, plan, play the approach (a divergence in it ends the
        episode: ``self.diverged``)."""
        scenario = replace(scenario, seed=int(self.np_random.integers(2**31 - 1)))
        self.close()
        self.episode = self.plan = None  # until this cell is built
        self.episode = episode = Episode(scenario)
        perceived = None
        if scenario.perception.enabled:
            with CameraRig(episode.sim.model, CAMERA, scenario.camera.width_px,
                           scenario.camera.height_px) as rig:
                perceived = episode.perceive(rig)
        self.plan = plan = episode.plan(self._planned_from(episode, perceived))
        self._dt_s = episode.control_dt_s
        self._knife = KnifeCommand(plan.knife, plan.cut_window_s, scenario.cut.speed_m_s,
                                   self.limits)
        self._sensing = Sensing(episode)
        self.diverged = False
        self._obs: np.ndarray | None = None
        self.clipped_actions = 0
        self.bounded_actions = 0
        self.torn_bindings = 0
        self.protective_stop = self.timed_out = False
        self.knife_force_peak_n = self.pull_force_peak_n = self.flesh_damage_s = 0.0
        self._knife_through_s: float | None = None
        self._pace = knife_pace(self.world)
        self._divergence = ""
        # The approach: both tools scripted until the knife is in at the entry and the jaws
        # hold the shank.
        handover_s = max(plan.cut_window_s.start_s, plan.schedule.grasp_s)
        try:
            while episode.sim.time_s < handover_s - 1e-9:
                t_next = episode.sim.time_s + self._dt_s
                episode.control_step(plan, plan.knife.sample(t_next), plan.pull.sample(t_next))
        except DivergenceError as exc:
            self._diverge(exc)
        self._start_s = episode.sim.time_s
        # A scripted knife slower than its plan takes the cut's time over the pace.
        slowed_s = (0.0 if self._drives_knife else
                    (plan.cut_window_s.end_s - self._start_s) * (1.0 / self._pace - 1.0))
        self._limit_s = (self.time_limit_s
                         or plan.end_s - self._start_s + slowed_s + TIME_MARGIN_S)
        self._pull = PullCommand(grasp_point(scenario, episode.scene.mesh),
                                 plan.pull.sample(self._start_s)[1], self.limits)
        self._reading = self._sensing.read(self._knife)
        self._obs = self._observe()
        return_freed_memory()  # the previous cell's heap, or RSS creeps up over many resets

    def _planned_from(self, episode: Episode, perceived: Any) -> Any:
        """What ``episode``'s cut is planned from: ``perceived`` (None: the true interface);
        a task whose perception errs (:class:`envs.steer.SteerEnv`) gives its own."""
        return perceived

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """One control step (20 ms by default) of the policy's action.

        Raises:
            gymnasium.error.ResetNeeded: before the first reset.
            InputError: an action that is not ``action_space.shape`` numbers (``field``
                "action").
        """
        if self.episode is None or self.plan is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        raw = self._checked(action)
        if self.diverged or self.protective_stop:
            return self._obs, 0.0, True, False, self._info({})
        episode, plan = self.episode, self.plan
        clipped = np.clip(np.nan_to_num(raw, nan=0.0), -1.0, 1.0)
        self.clipped_actions += int(np.count_nonzero(clipped != raw))
        t_next = episode.sim.time_s + self._dt_s
        progress = self._knife.progress
        cleared = self._cleared_fraction() if progress >= 1.0 else None
        knife_target, grasp_target, knife_s = self._targets(clipped, t_next)
        try:
            released = episode.control_step(plan, knife_target, grasp_target, knife_s)
        except DivergenceError as exc:
            self._diverge(exc)
            return self._obs, -self.reward_params.divergence, True, False, self._info({})
        before, self._reading = self._reading, self._sensing.read(self._knife)
        torn_now = len(released.get(ReleaseRule.TEARING, ()))
        self.torn_bindings += torn_now
        torn = torn_now / len(episode.scene.aponeurosis)
        terms = reward_terms(self.reward_params, before, self._reading, torn,
                             self._knife.progress - progress,
                             policy_cutting=self._drives_knife and progress < 1.0,
                             clear_advance=0.0 if cleared is None
                             else self._cleared_fraction() - cleared)
        self._watch(terms)
        self._obs = self._observe()
        if self.success:
            terms["success"] = self.reward_params.success
        terminated = (self.success or self.protective_stop
                      or self.torn_fraction > self.task.max_torn_fraction)
        truncated = not terminated and self.elapsed_s >= self._limit_s - 1e-9
        if truncated and self.task.cycle_time_fails:
            self.timed_out = True
            terms["timeout"] = -self.reward_params.timeout
            # The same reward either way: only the episode's end is flagged otherwise.
            terminated, truncated = self.timeout_terminates, not self.timeout_terminates
        if self.render_mode == "human":
            self.render()
        return self._obs, float(sum(terms.values())), terminated, truncated, self._info(terms)

    def _checked(self, action: Any) -> np.ndarray:
        """``action`` as an array of the action space's shape (a leading or trailing axis of
        one, as a batch of one gives, is dropped)."""
        shape = self.action_space.shape
        try:
            given = np.asarray(action)
            if given.dtype.kind not in "biuf":  # text, complex numbers, objects, huge ints
                raise TypeError(given.dtype)
            raw = given.astype(float)
        except (TypeError, ValueError):
            raise InputError(None, "action", f"expected {shape[0]} numbers, got "
                             f"{action!r:.80}") from None
        if raw.squeeze().shape != shape:
            raise InputError(None, "action", f"expected shape {shape} ({self.driven} driven), "
                             f"got shape {raw.shape}")
        return raw.reshape(shape)

    def _watch(self, terms: dict[str, float]) -> None:
        """Keep the episode's peaks and damage, and stop the cell past a force limit."""
        reading, task = self._reading, self.task
        knife_n, pull_n = reading.knife_force_magnitude_n, reading.pull_force_magnitude_n
        self.knife_force_peak_n = max(self.knife_force_peak_n, knife_n)
        self.pull_force_peak_n = max(self.pull_force_peak_n, pull_n)
        if reading.blade_in_flesh:
            self.flesh_damage_s += self._dt_s
        if knife_n > task.knife_stop_force_n or pull_n > task.pull_stop_force_n:
            self.protective_stop = True
            terms["protective_stop"] = -self.reward_params.protective_stop

    def _targets(self, action: np.ndarray, t_next: float) -> tuple[Pose, Pose, float]:
        """The knife's and the grasp site's targets for the step to ``t_next``, and the plan's
        time the knife is at."""
        plan = self.plan
        if self._drives_knife:
            knife_target, hits = self._knife.advance(action[:KNIFE_DIMS], self._dt_s)
            knife_s = self._knife.tau_s
            self.bounded_actions += hits
        else:
            knife_s = self._knife_clock_s(t_next)
            knife_target = plan.knife.sample(knife_s)
            self._knife.follow(knife_s)
        if self._drives_pull:
            grasp_target, hits = self._pull.advance(action[-PULL_DIMS:], self._dt_s)
            self.bounded_actions += hits
        else:
            grasp_target = plan.pull.sample(self._pull_clock_s(t_next))
        return knife_target, grasp_target, knife_s

    def _knife_clock_s(self, t_next: float) -> float:
        """The plan's time the scripted knife is at: it cuts at ``knife_pace`` of the plan's
        speed, then leaves the cut as planned."""
        start, end = self.plan.cut_window_s
        if self._knife_through_s is None:
            knife_s = self._start_s + (t_next - self._start_s) * self._pace
            if knife_s < end:
                return max(knife_s, start)
            self._knife_through_s = t_next
        return end + t_next - self._knife_through_s

    def _pull_clock_s(self, t_next: float) -> float:
        """The plan's time the scripted pull follows: the policy's knife's while it cuts (a
        pull ahead of the knife tears what it has not cut), then the time since it came
        through, past the cut's end."""
        if not self._drives_knife:
            return t_next
        cut_end = self.plan.cut_window_s.end_s
        if self._knife.progress < 1.0:
            return max(self._knife.tau_s, self._start_s)
        if self._knife_through_s is None:
            self._knife_through_s = t_next
        return cut_end + t_next - self._knife_through_s

    def _diverge(self, exc: DivergenceError) -> None:
        self.diverged = True
        self._divergence = str(exc)

    def _observe(self) -> np.ndarray:
        if self.diverged and self._obs is not None:
            return self._obs  # the state is no longer data: keep the last finite view
        return self._observation()

    def _observation(self) -> np.ndarray:
        """The observation of the cell now (a task that sees more extends it)."""
        return observe(self._reading, self._knife, self._pull,
                       min(1.0, self.elapsed_s / self._limit_s))

    def _info(self, terms: dict[str, float]) -> dict[str, Any]:
        info: dict[str, Any] = {
            "diverged": self.diverged,
            "released_fraction": self._reading.released_fraction,
            "torn_fraction": self.torn_fraction,
            "clipped_actions": self.clipped_actions,
            "bounded_actions": self.bounded_actions,
            "sim_time_s": self.episode.sim.time_s,
            "reward_terms": terms,
            "world": copy.deepcopy(self.world),  # the caller keeps each step's info
            "redraws": list(self.redraws),
            "is_success": self.success,
            "success": self.success,  # deprecated alias of is_success, for one release
            "protective_stop": self.protective_stop,
            "timed_out": self.timed_out,
            "knife_force_peak_n": self.knife_force_peak_n,
            "pull_force_peak_n": self.pull_force_peak_n,
            "flesh_damage_s": self.flesh_damage_s,
            "elapsed_s": self.elapsed_s,
        }
        if self.diverged:
            info["divergence"] = self._divergence
        return info

    @property
    def torn_fraction(self) -> float:
        """Fraction of the bindings torn since the policy took over."""
        return self.torn_bindings / len(self.episode.scene.aponeurosis)

    @property
    def success(self) -> bool:
        """The task's fraction released with no more than its fraction torn, the shank its
        clearing distance away, the cell running (no protective stop, no divergence)."""
        return (self._reading.released_fraction >= self.task.separated_fraction
                and self.torn_fraction <= self.task.max_torn_fraction
                and self.cleared_m >= self.task.clear_distance_m
                and not self.protective_stop and not self.diverged)

    def _cleared_fraction(self) -> float:
        clear_m = self.task.clear_distance_m
        return min(1.0, self.cleared_m / clear_m) if clear_m > 0 else 0.0

    @property
    def cleared_m(self) -> float:
        """How far the grasp site is from where it held the shank when the policy took over,
        m."""
        return float(np.linalg.norm(self._reading.grasp_m - self._pull.origin_m))

    @property
    def elapsed_s(self) -> float:
        """Simulated time since the policy took over, s."""
        return self.episode.sim.time_s - self._start_s

    def close(self) -> None:
        """Free the renderer's GL context."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
