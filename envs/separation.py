"""The muscle separation task as Gymnasium envs: the policy drives the knife, the pull or both
through the cell's mink IK, one action per 20 ms control step.

Each episode builds the cell afresh (so that every variation applies), plans the cut and the
pull as the scripted episode does, and plays the plan's approach (knife down to the entry at
depth, jaws closed on the shank) before the policy takes over.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any, ClassVar, Literal, TypeVar

import gymnasium as gym
import numpy as np

from cell.config import updated
from cell.errors import DivergenceError, InputError, MusclecellError
from cell.memory import return_freed_memory
from cell.robots.camera import CameraRig
from cell.robots.names import CAMERA
from cell.sim.assembly import grasp_point
from cell.sim.episode import Episode, EpisodePlan
from cell.sim.scenario import Scenario
from cell.tissue.aponeurosis import ReleaseRule
from cell.tissue.geometry import MuscleShape
from controllers.gripper import PullPlan
from envs.commands import KnifeCommand, Pose, PullCommand
from envs.observation import (
    OBSERVATION_BOUND,
    OBSERVATION_NAMES,
    Sensing,
    observe,
)
from envs.options import apply_options, knife_pace, merge_options
from envs.params import ActionLimits, RewardParams, TaskParams
from envs.randomization import Randomization, check_ranges, draw, load_randomization
from envs.render import CellRenderer
from envs.reward import reward_terms

#: Training resolution of the tissue (m); the cell's own default, 0.025 m, is for evaluation.
COARSE_CELL_SIZE_M = 0.05
#: The envs' pull-off speed once the knife is out, m/s (the scripted episode's is 0.02 m/s):
#: the pull's last phase holds no decision, so it runs at the pull action's top speed's 80 %.
ENV_PULL_SPEED_M_S = 0.04
#: ``Cut-v0``'s task: the knife must do the separating, so at most a quarter may tear (the
#: scripted plan's 15 mm clearance above the table leaves the lowest bindings to the pull's
#: tearing: 27 % of them on the nominal world, seed 0); the scripted pull takes the shank
#: away, so the knife's task ends when the bindings are released.
CUT_TASK = TaskParams(max_torn_fraction=0.25, clear_distance_m=0.0)
#: ``Pull-v0``'s task: the scripted knife cuts down to the table, so what tears beyond its own
#: few is the pull's doing: at most a quarter, and the shank taken 5 cm away.
PULL_TASK = TaskParams(max_torn_fraction=0.25, clear_distance_m=0.05)
#: ``Pull-v0``'s planned cut runs this far above the table (m), under the reset's options.
PULL_KNIFE_CLEARANCE_M = 0.002
#: Simulated time past the scripted plan's end the default time limit allows, s.
_TIME_MARGIN_S = 2.0
#: Draws a reset makes before it gives up on a randomised world that fails to build or
#: diverges on the approach.
MAX_DRAWS = 5

Driven = Literal["both", "knife", "pull"]
Parameters = TypeVar("Parameters", ActionLimits, RewardParams, TaskParams)
_KNIFE_DIMS = 4
_PULL_DIMS = 3


class MuscleSeparationEnv(gym.Env[np.ndarray, np.ndarray]):
    """Separate the shank from the round: cut along the aponeurosis and pull.

    Actions (Box in [-1, 1], scaled by ``limits``; out-of-range entries are clipped and
    counted in ``info["clipped_actions"]``): for the knife its speed along its planned path
    and the offsets from it it should go to (across, depth, yaw), for the gripper the grasp
    site's displacement it should go to (x, y, z, world); the targets go there at the limits'
    speeds (see :mod:`envs.commands`).
    ``driven`` picks which the policy drives; the other follows the scripted plan.
    Observations: see :mod:`envs.observation`. Reward: see :class:`RewardParams`.
    When the policy drives the knife alone, the scripted pull keeps pace with the knife: it
    follows the plan at the plan's time where the knife is, and pulls off once the knife is
    through. Terminated on success or failure as ``task`` (:class:`TaskParams`) defines them:
    success when the bindings are released with few torn and the shank is clear
    (``info["success"]``), failure when too many tore, on a protective stop
    (``info["protective_stop"]``) or when the simulation diverges (``info["diverged"]``, the
    last finite observation is returned), and at ``time_limit_s`` of simulated time after the
    policy takes over (default: the scripted plan's length, the cut's part stretched by a
    scripted knife's ``knife_pace``, plus 2 s): a failure of the cell's cycle time
    (``info["timed_out"]``), or a truncation where ``task.cycle_time_fails`` is False. The
    final info also holds the episode's peak tool forces (``knife_force_peak_n``,
    ``pull_force_peak_n``), ``flesh_damage_s`` (time the blade touched muscle with no binding
    under it) and ``elapsed_s``.

    Args:
        scenario: the base cell and plan (default :class:`Scenario` at the training
            resolution, ``COARSE_CELL_SIZE_M``).
        cell_size_m: tissue resolution, m (0.05 to train, 0.025 to evaluate); None keeps
            the scenario's.
        perception: plan from the camera (paper Sec. 5, 0.3-1 s per reset) instead of the
            generator's known interface.
        options: variations applied at every reset (see :mod:`envs.options`); a reset's own
            ``options`` apply on top, key by key (a reset's material keeps these options'
            fibre direction, a reset's shape these options' other shape fields).
        randomize: draw a world from ``randomization`` at every reset, from the env's random
            generator (so the reset's seed fixes it), under ``options`` and the reset's own
            options key by key; ``reset(options={"randomize": False})`` evaluates on the
            nominal world. ``info["world"]`` holds the variations applied. A drawn world that
            fails to build or diverges before the policy takes over is drawn again (up to
            ``MAX_DRAWS`` times; ``info["redraws"]`` says why).
        randomization: the distribution (see :mod:`envs.randomization`): a file, or None for
            the package's default.
        limits, reward, task: action scaling, reward weights, success and stops: objects, or
            mappings of their fields over the defaults (as JSON keyword arguments give them).
        time_limit_s: episode length after the approach, s of simulated time.
        driven: ``"both"``, ``"knife"`` or ``"pull"``.
        render_mode: None or ``"rgb_array"``.

    Example:
        >>> env = MuscleSeparationEnv(driven="knife")
        >>> obs, info = env.reset(seed=0, options={"shape": {"length_m": 0.4}})
        >>> obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(self, scenario: Scenario | None = None,
                 cell_size_m: float | None = None, perception: bool = False,
                 options: Mapping[str, Any] | None = None,
                 limits: ActionLimits | Mapping[str, Any] | None = None,
                 reward: RewardParams | Mapping[str, Any] | None = None,
                 time_limit_s: float | None = None, driven: Driven = "both",
                 render_mode: str | None = None, randomize: bool = True,
                 randomization: str | Path | Randomization | None = None,
                 task: TaskParams | Mapping[str, Any] | None = None) -> None:
        if driven not in ("both", "knife", "pull"):
            raise InputError(None, "driven", f"must be both, knife or pull, got {driven!r}")
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise InputError(None, "render_mode", f"must be None or rgb_array, got "
                             f"{render_mode!r}")
        if time_limit_s is not None and not time_limit_s > 0:
            raise InputError(None, "time_limit_s", f"must be > 0, got {time_limit_s}")
        if scenario is None:
            scenario = Scenario(tissue=MuscleShape(cell_size_m=COARSE_CELL_SIZE_M),
                                pull=PullPlan(speed_m_s=ENV_PULL_SPEED_M_S))
        if cell_size_m is not None:
            scenario = replace(scenario, tissue=replace(scenario.tissue, cell_size_m=cell_size_m))
        self.base = replace(scenario, perception=replace(scenario.perception,
                                                         enabled=perception))
        self.options = dict(options or {})
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
        self.limits = _parameters(ActionLimits, limits, "limits")
        self.reward_params = _parameters(RewardParams, reward, "reward")
        self.task = _parameters(TaskParams, task, "task")
        self.time_limit_s = time_limit_s
        self.driven = driven
        self.render_mode = render_mode
        self._drives_knife = driven in ("both", "knife")
        self._drives_pull = driven in ("both", "pull")
        dims = _KNIFE_DIMS * self._drives_knife + _PULL_DIMS * self._drives_pull
        self.action_space = gym.spaces.Box(-1.0, 1.0, (dims,), np.float32)
        self.observation_space = gym.spaces.Box(-OBSERVATION_BOUND, OBSERVATION_BOUND,
                                                (len(OBSERVATION_NAMES),), np.float32)
        self.episode: Episode | None = None
        self.plan: EpisodePlan | None = None
        self.world: dict[str, Any] = {}
        self.redraws: list[str] = []
        self._renderer: CellRenderer | None = None

    # -- episode --------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        """Draw a world (unless ``options["randomize"]`` is False or the env does not
        randomise), build a fresh cell with it (``options`` over the constructor's over the
        draw), plan, play the approach; the draw and the scenario's seed (sensor noise,
        camera noise) come from the env's random generator."""
        super().reset(seed=seed)
        options = dict(options or {})
        randomize = options.pop("randomize", self.randomize)
        if not isinstance(randomize, bool):
            raise InputError(None, "randomize", f"expected true or false, got {randomize!r}")
        apply_options(self.base, self.options, options)  # a bad option is no bad draw
        self.redraws = []
        for attempt in range(1, MAX_DRAWS + 1):
            last = not randomize or attempt == MAX_DRAWS
            drawn = draw(self.randomization, self.np_random) if randomize else {}
            self.world = merge_options(drawn, self.options, options)
            try:
                self._start(apply_options(self.base, self.world))
            except MusclecellError as exc:
                if last:
                    raise
                self.redraws.append(str(exc))
                continue
            if last or not self.diverged:
                break
            self.redraws.append(self._divergence)
        return self._obs, self._info({})

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
        self.plan = plan = episode.plan(perceived)
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
                         or plan.end_s - self._start_s + slowed_s + _TIME_MARGIN_S)
        self._pull = PullCommand(grasp_point(scenario, episode.scene.mesh),
                                 plan.pull.sample(self._start_s)[1], self.limits)
        self._reading = self._sensing.read(self._knife)
        self._obs = self._observe()
        return_freed_memory()  # the previous cell's heap, or RSS creeps up over many resets

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """One control step (20 ms by default) of the policy's action."""
        if self.episode is None or self.plan is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        if self.diverged or self.protective_stop:
            return self._obs, 0.0, True, False, self._info({})
        episode, plan = self.episode, self.plan
        raw = np.asarray(action, dtype=float).reshape(self.action_space.shape)
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
            self.timed_out, terminated, truncated = True, True, False
            terms["timeout"] = -self.reward_params.timeout
        return self._obs, float(sum(terms.values())), terminated, truncated, self._info(terms)

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
            knife_target, hits = self._knife.advance(action[:_KNIFE_DIMS], self._dt_s)
            knife_s = self._knife.tau_s
            self.bounded_actions += hits
        else:
            knife_s = self._knife_clock_s(t_next)
            knife_target = plan.knife.sample(knife_s)
            self._knife.follow(knife_s)
        if self._drives_pull:
            grasp_target, hits = self._pull.advance(action[-_PULL_DIMS:], self._dt_s)
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
            "success": self.success,
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

    # -- baselines ------------------------------------------------------------------------

    def scripted_action(self) -> np.ndarray:
        """The action that replays the scripted episode's plan from here: the knife along its
        path at the plan's speed with no offset, the grasp site at the plan's next point, on
        the plan's clock. It reads the plan, so it is a privileged baseline, not a policy of
        the observation."""
        parts = []
        if self._drives_knife:
            along = (2.0 * self._knife.speed_m_s / self.limits.knife_along_speed_m_s - 1.0
                     if self._knife.progress < 1.0 else -1.0)
            parts.append([along, 0.0, 0.0, 0.0])
        if self._drives_pull:
            goal = self.plan.pull.sample(self.episode.sim.time_s + self._dt_s)[0]
            parts.append(np.cbrt((goal - self._pull.origin_m) / self.limits.pull_max_distance_m))
        return np.clip(np.concatenate(parts), -1.0, 1.0).astype(np.float32)

    # -- rendering ------------------------------------------------------------------------

    def render(self) -> np.ndarray | None:
        """The LWR camera's view beside a fixed overview, (240, 640, 3) uint8, in
        ``rgb_array`` mode."""
        if self.render_mode != "rgb_array" or self.episode is None:
            return None
        if self._renderer is None:
            scenario = self.episode.scenario
            look_at = np.array([scenario.layout.meat_x_m, 0.0,
                                scenario.layout.table_height_m + 0.05])
            self._renderer = CellRenderer(self.episode.sim.model, look_at)
        return self._renderer.render(self.episode.sim.data)

    def close(self) -> None:
        """Free the renderer's GL context."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def _parameters(kind: type[Parameters], value: Parameters | Mapping[str, Any] | None,
                name: str) -> Parameters:
    """``value`` itself, the defaults for None, or the defaults with a mapping's fields."""
    if value is None or isinstance(value, Mapping):
        return updated(kind(), value or {}, section=name)
    if not isinstance(value, kind):
        raise InputError(None, name, f"expected {kind.__name__} or a mapping, got {value!r}")
    return value


class CutEnv(MuscleSeparationEnv):
    """:class:`MuscleSeparationEnv` with the policy on the knife only; the pull is scripted.

    Example:
        >>> env = CutEnv(cell_size_m=0.05)
    """

    def __init__(self, **kwargs: Any) -> None:
        if isinstance(kwargs.get("task"), Mapping):
            kwargs["task"] = updated(CUT_TASK, kwargs["task"], section="task")
        kwargs.setdefault("task", CUT_TASK)
        super().__init__(driven="knife", **kwargs)


class PullEnv(MuscleSeparationEnv):
    """:class:`MuscleSeparationEnv` with the policy on the pull only; the knife is scripted:
    its plan cuts ``PULL_KNIFE_CLEARANCE_M`` above the table (unless the options set
    ``cut_table_clearance_m``) at the world's ``knife_pace`` of the plan's speed, so that the
    pull must keep pace with the knife it sees, not with the plan's clock (``PULL_TASK``).

    Example:
        >>> env = PullEnv(cell_size_m=0.05)
    """

    def __init__(self, **kwargs: Any) -> None:
        if isinstance(kwargs.get("task"), Mapping):
            kwargs["task"] = updated(PULL_TASK, kwargs["task"], section="task")
        kwargs.setdefault("task", PULL_TASK)
        kwargs["options"] = {"cut_table_clearance_m": PULL_KNIFE_CLEARANCE_M,
                             **(kwargs.get("options") or {})}
        super().__init__(driven="pull", **kwargs)

