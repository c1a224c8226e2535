"""The muscle separation task as a Gymnasium env: the policy drives the knife, the pull or both
through the cell's mink IK, one action per control step (:class:`MuscleSeparationEnv`, its
manual); its tasks with one tool each are in :mod:`envs.tasks`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cell.errors import InputError, MusclecellError
from envs.core import SeparationCore
from envs.options import apply_options, merge_options
from envs.randomization import draw
from envs.render import CellRenderer, CellWindow
from envs.settings import MAX_DRAWS


class MuscleSeparationEnv(SeparationCore):
    """Separate the shank from the round: cut along the aponeurosis and pull
    (``musclecell/MuscleSeparation-v2``).

    .. rubric:: Description

    Two beef muscles lie on a table, bound along their interface (the aponeurosis) by
    springs that a knife cuts and a pull tears. A knife arm cuts along the interface's top
    line while a gripper arm holds the shank (the smaller muscle) and pulls it away from the
    round. The policy drives the knife, the pull or both (``driven``); a tool it does not
    drive follows the scripted plan. Each reset builds the cell afresh on a world drawn from
    the domain randomisation (:mod:`envs.randomization`), plans the cut and the pull
    (:mod:`envs.settings`) and plays the plan's approach; the policy then acts once per
    control step (20 ms) until the episode ends.

    .. rubric:: Action space

    ``Box(-1, 1, (7,), float32)`` with ``driven="both"``: the knife's four entries, then the
    pull's three (a task drives one tool and has its entries alone). Out-of-range entries are
    clipped (counted in ``info["clipped_actions"]``), NaN is 0. The scaling is ``limits``
    (:class:`~envs.params.ActionLimits`; its defaults in brackets). Offsets and the grasp
    displacement are places the target moves to at the limit's speed, not velocities
    (:mod:`envs.commands`).

    =====  =================  =====  ==================================================
    Index  Action             Unit   Meaning
    =====  =================  =====  ==================================================
    0      knife along speed  m/s    speed along the planned path: -1 stands, 1 is
                                     ``knife_along_speed_m_s``
    1      knife across       m      offset across the path wanted, times
                                     ``knife_max_across_m``
    2      knife depth        m      offset down the blade's axis wanted, times
                                     ``knife_max_depth_m``
    3      knife yaw          rad    turn about the blade's axis wanted, times
                                     ``knife_max_yaw_rad``
    4-6    grasp x, y, z      m      the grasp site's displacement wanted (world axes),
                                     cubed times ``pull_max_distance_m``
    =====  =================  =====  ==================================================

    .. rubric:: Observation space

    ``Box(-100, 100, (35,), float32)``, named by :data:`envs.observation.OBSERVATION_NAMES`
    (the env's ``observation_names``) and read by :class:`envs.observation.Sensing`; entries
    are scaled to order one (lengths in cm), clipped to the bounds, non-finite readings 0. The
    path frame is the planned tip pose at the knife's place on its path: x along the edge, y
    across, z down the blade.

    =====  ===========================  =======  ========================================
    Index  Names                        Unit     Meaning
    =====  ===========================  =======  ========================================
    0-2    ``tip_along_cm``,            cm       the knife tip from its path point,
           ``tip_across_cm``,                    path frame
           ``tip_depth_cm``
    3      ``tip_height_cm``            cm       the tip above the table's top
    4      ``blade_yaw_rad``            rad      the edge's yaw from the path's tangent
    5      ``path_progress``            1        fraction of the cut's path reached
    6-8    ``command_across_cm``,       cm, cm,  the target's offsets now
           ``command_depth_cm``,        rad
           ``command_yaw_rad``
    9-17   ``path_1cm_along_cm`` ..     cm       the path's points 1, 2 and 4 cm ahead,
           ``path_4cm_depth_cm``                 from the tip, path frame
    18-20  ``knife_fx`` ..              10 N     the knife's force sensor, sensor frame
           ``knife_fz``
    21-23  ``knife_tx`` ..              N m      the knife's torque sensor, sensor frame
           ``knife_tz``
    24-26  ``grasp_dx`` ..              0.1 m    the grasp site from where it held the
           ``grasp_dz``                          shank at the hand-over, world frame
    27-29  ``pull_fx`` ..               10 N     the gripper's force sensor, sensor frame
           ``pull_fz``
    30     ``released_fraction``        1        bindings released of all
    31     ``released_ahead_fraction``  1        of the bindings up to 5 cm ahead of the
                                                 tip along the path, those released
    32     ``strain_near_cut``          tearing  mean stretch beyond rest of the bound
                                        stretch  bindings within 5 cm of the tip
    33     ``strain_max``               tearing  the largest stretch of a bound binding
                                        stretch
    34     ``time_fraction``            1        time since the hand-over over the time
                                                 limit
    =====  ===========================  =======  ========================================

    .. rubric:: Rewards

    A step's reward is the sum of the terms in ``info["reward_terms"]``, weighted by
    ``reward`` (:class:`~envs.params.RewardParams`, which gives the formula): the change of
    the released fraction (``progress``), the knife's advance along its path
    (``cut_progress``), the shank's advance toward the task's clearing distance once the
    knife is through (``clearing``); costs for the blade in muscle with no binding under it
    or off the true interface (``damage``), tool forces over their limits (``force``), the
    fraction torn rather than cut (``tearing``), the policy's blade left high over the table
    while it cuts (``uncut_depth``) and every step (``time``). The step that succeeds earns
    ``success``; a divergence, a protective stop and a timeout cost their weights.

    .. rubric:: Starting state

    ``reset(seed=...)`` draws a world from the env's random generator (unless it does not
    randomise), builds the cell with it, plans, and plays the approach with both tools
    scripted: the knife goes in at the cut's entry at depth, the jaws close on the shank.
    The policy takes over there; the first observation is the cell at that moment.

    .. rubric:: Episode end

    Termination (``task``, :class:`~envs.params.TaskParams`): success
    (``info["is_success"]``: the task's fraction released with no more than its fraction
    torn, the shank its clearing distance away; ``info["success"]`` is its deprecated alias,
    for one release); more torn than the task allows; a protective stop (a tool's force
    sensor over its stop, ``info["protective_stop"]``); a diverged simulation
    (``info["diverged"]``; the last finite observation is returned). Truncation: the time
    limit, ``time_limit_s`` of simulated time after the hand-over (default: the plan's
    remaining length, a slow scripted knife's cut stretched by its ``knife_pace``, plus
    ``envs.settings.TIME_MARGIN_S``). With ``task.cycle_time_fails`` (the default) the
    unfinished episode has failed the cell's cycle time there: ``info["timed_out"]`` and the
    ``timeout`` cost; ``timeout_terminates=True`` flags that step as a termination instead
    (the behaviour before this release, which the published evaluations and trainings used;
    rewards and observations are the same either way). Gymnasium's ``TimeLimit`` bounds an
    episode at :data:`envs.registration.MAX_EPISODE_STEPS` steps, beyond every default time
    limit. The final info holds the episode's ``knife_force_peak_n``, ``pull_force_peak_n``,
    ``flesh_damage_s`` (time the blade touched muscle with no binding under it) and
    ``elapsed_s``.

    .. rubric:: Arguments

    ``gymnasium.make("musclecell/MuscleSeparation-v2", **kwargs)`` passes these:

    Args:
        scenario: the base cell and plan (default :func:`envs.settings.task_scenario`: the
            envs' own cut and pull at ``COARSE_CELL_SIZE_M``).
        cell_size_m: tissue resolution, m; None keeps the scenario's (the default cell's
            is :data:`envs.settings.COARSE_CELL_SIZE_M`, 0.05, on which the envs train and
            the published evaluations ran; 0.025, the scripted episode's, is finer and
            slower).
        perception: plan from the camera (paper Sec. 5) instead of the generator's known
            interface.
        options: variations applied at every reset (:mod:`envs.options`); a reset's own
            ``options`` apply on top, key by key.
        randomize: draw a world from ``randomization`` at every reset (the seed fixes it),
            under ``options`` and the reset's options; a world that fails to build or
            diverges before the hand-over is drawn again (up to ``MAX_DRAWS`` times;
            ``info["redraws"]`` says why). ``info["world"]`` holds the variations applied.
        randomization: the distribution: a TOML file, or None for the package's default.
        limits, reward, task: action scaling, reward weights, success and stops: objects,
            or mappings of their fields over the defaults (as JSON keyword arguments give).
        time_limit_s: episode length after the hand-over, s of simulated time.
        timeout_terminates: the time limit under ``task.cycle_time_fails`` ends the episode
            as a termination (True, as before this release) or a truncation (False).
        driven: ``"both"``, ``"knife"`` or ``"pull"``.
        render_mode: None, ``"rgb_array"`` (the camera arm's view beside an overview) or
            ``"human"`` (MuJoCo's viewer in a window, following each step; needs a display).
        width, height: the size of each of the two ``rgb_array`` views, px.

    ``reset(seed=None, options=None)``: ``options`` holds variations of
    :mod:`envs.options` for this episode and ``"randomize"`` (False: the nominal world).

    .. rubric:: Version history

    - v2, this release: ``info["is_success"]`` (``success`` stays one release); the time
      limit is a truncation (``timeout_terminates=True``: a termination, as before), with
      ``max_episode_steps`` registered; observations and rewards unchanged.
    - v2: the knife meets the material's cutting model in the seam (the scenario's
      ``aponeurosis.knife_force = "cutting"``: the seam's toughness on the length of edge in
      uncut seam, the faces' friction, slicing and rate from the material's ``[cutting]``
      table) instead of a share of the synthetic force curve: the knife's force while
      cutting, the force rule's threshold and what tears change; ``force_scale`` scales the
      seam's toughness. Everything else as v1. The ``-v1`` ids still make v1's envs (the
      curve), seeded rollouts unchanged.
    - v1: the v0 envs' behaviour, seeded rollouts equal, under a new id: this manual; the
      cut and pull written in the env (:mod:`envs.settings`), not taken from the library's
      defaults; options named as their scenario keys (``aponeurosis_stiffness_n_m``,
      ``perception_noise_sigma_at_1m_m``, ``tissue``; the old names warn); a wrongly shaped
      action raises :class:`~cell.errors.InputError`.
    - v0: the first version; its action's meaning and its reward changed under the same id.

    Example:
        >>> env = MuscleSeparationEnv(driven="knife")
        >>> obs, info = env.reset(seed=0, options={"tissue": {"length_m": 0.4}})
        >>> obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    """

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
        if self.render_mode == "human":
            self.render()
        return self._obs, self._info({})

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

    def render(self) -> np.ndarray | None:
        """In ``rgb_array`` mode the LWR camera's view beside a fixed overview, (height,
        2 width, 3) uint8; in ``human`` mode the window shows the present step (None)."""
        if self.render_mode is None or self.episode is None:
            return None
        sim = self.episode.sim
        if self._renderer is None and self.render_mode == "human":
            self._renderer = CellWindow(sim.model, sim.data)
        if self._renderer is None:
            scenario = self.episode.scenario
            look_at = np.array([scenario.layout.meat_x_m, 0.0,
                                scenario.layout.table_height_m + 0.05])
            self._renderer = CellRenderer(sim.model, look_at, self.width, self.height)
        return self._renderer.render(sim.data)
