"""Parameters of the separation envs: how actions scale to the tools and how steps are scored."""

from __future__ import annotations

from dataclasses import dataclass

from cell.config import require_flag, require_non_negative, require_positive
from cell.errors import InputError


@dataclass(frozen=True)
class ActionLimits:
    """What an action of 1 means for each tool, and the bounds its target stays within (SI).

    The knife moves in the frame of its planned path: ``along`` it (forward, at up to
    ``knife_along_speed_m_s``), and to offsets ``across`` it (the blade's normal, within
    ``knife_max_across_m``, at up to ``knife_across_speed_m_s``), in ``depth`` (the blade's
    axis, within ``knife_max_depth_m``) and in yaw about its axis (within
    ``knife_max_yaw_rad`` of the path's tangent, at up to ``knife_yaw_rate_rad_s``). The
    grasp site moves to displacements within ``pull_max_distance_m`` of the grasp point
    (never more than ``pull_max_sink_m`` below it: the table lies beneath) at up to
    ``pull_speed_m_s`` along each world axis.

    Example:
        >>> ActionLimits(knife_along_speed_m_s=0.05).knife_max_across_m
        0.004
    """

    knife_along_speed_m_s: float = 0.08
    knife_across_speed_m_s: float = 0.01
    knife_depth_speed_m_s: float = 0.02
    knife_yaw_rate_rad_s: float = 0.5
    # The knife's offsets are corrections of a perceived path, whose error is millimetres (the
    # perception page of the docs): 4 mm across and 0.1 rad of yaw (5 mm at the
    # blade's back) cover them, and wider ones only let a policy's exploration plough the
    # muscles sideways (design notes: a PPO knife with wider bounds tore the bindings).
    knife_max_across_m: float = 0.004
    knife_max_depth_m: float = 0.03
    knife_max_yaw_rad: float = 0.1
    pull_speed_m_s: float = 0.05
    pull_max_distance_m: float = 0.2
    pull_max_sink_m: float = 0.005

    def __post_init__(self) -> None:
        require_positive(self)


@dataclass(frozen=True)
class RewardParams:
    """Weights of the reward's terms; one step's reward is

    ``progress * d(released fraction) + cut_progress * d(knife's progress along its path)
    + clearing * d(cleared fraction) - damage - force - tearing - uncut_depth - time_per_step``

    (the second term is dense shaping: the bindings release a few at a time; the third counts
    the grasp site's distance from where it held the shank, as a fraction of the task's
    ``clear_distance_m``, up to 1, where the task asks for one, from the step the knife is
    through: before it, moving the shank tears what the knife has not cut, and a PPO pull
    paid for the distance then learned to pull early)

    where damage is ``contact_per_step`` for each step the blade touches muscle with no
    binding under it, plus ``off_interface_per_m`` times the blade tip's distance from the true
    interface beyond ``interface_tolerance_m`` while it touches muscle; force is
    ``force_per_n`` times the knife force (N) above ``knife_force_limit_n`` plus the pull force
    above ``pull_force_limit_n`` (80 % of :class:`TaskParams`' stops: a cut's force stays
    clear of them, as it must for a policy to learn that cutting pays), at most
    ``force_cap_per_step`` (a blade jammed on the table would otherwise outweigh everything
    else); uncut_depth is ``uncut_depth_per_m`` times the policy's blade tip's height above
    ``cut_reach_m`` over the table, per step from the entry until its knife is through (the
    bindings lowest down hold until the tip is that close, and a cut that leaves them leaves
    them to tear: the cost says so at the step the blade passes high, not at the pull-off a
    second later; from the entry on, so that waiting there is no way around it); tearing is
    ``tearing`` times the fraction of the
    bindings torn rather than cut (more than tearing gains as progress, so that a torn
    binding costs and a cut one pays: separating by pulling alone is the damage the knife is
    there to avoid). A diverged simulation costs
    ``divergence``, a protective stop (:class:`TaskParams`) ``protective_stop``, an episode
    not done within the cell's cycle time ``timeout``; the step that succeeds earns
    ``success``.

    Example:
        >>> RewardParams(time_per_step=0.0).progress
        10.0
    """

    progress: float = 10.0
    cut_progress: float = 5.0
    clearing: float = 3.0
    contact_per_step: float = 0.005
    off_interface_per_m: float = 2.0
    interface_tolerance_m: float = 0.003
    knife_force_limit_n: float = 28.0
    pull_force_limit_n: float = 64.0
    force_per_n: float = 0.01
    force_cap_per_step: float = 0.05
    tearing: float = 12.0
    uncut_depth_per_m: float = 3.0
    cut_reach_m: float = 0.003
    time_per_step: float = 0.002
    divergence: float = 10.0
    protective_stop: float = 5.0
    timeout: float = 5.0
    success: float = 5.0

    def __post_init__(self) -> None:
        require_non_negative(self)


@dataclass(frozen=True)
class TaskParams:
    """When an episode succeeds, and when the cell stops it (SI units).

    It succeeds when ``separated_fraction`` of the bindings are released with no more than
    ``max_torn_fraction`` of them torn (rather than cut) since the policy took over (tearing
    the muscles apart is the damage the knife is there to avoid) and the grasp site has taken
    the shank ``clear_distance_m`` away from where it held it then (0: the bindings' release
    is enough). It fails, and ends at once,
    when more than ``max_torn_fraction`` have torn (it can no longer succeed), on a protective
    stop (the knife's force/torque sensor reads more than ``knife_stop_force_n`` or the
    gripper's more than ``pull_stop_force_n``, as a real cell's force limits stop the arms:
    a blade driven into the table reads far more than a cut does) or when the
    simulation diverges. An episode unfinished at the time limit is truncated there; with
    ``cycle_time_fails`` it has failed too (``timed_out``, the reward's ``timeout`` cost: the
    cell's cycle time is part of the task, and the observation carries the time, so a policy
    cannot wait out a cut it has not finished), with ``cycle_time_fails=False`` it has not
    (Gymnasium's time limit outside the task). The env's ``timeout_terminates`` flags the
    failed cycle time as a termination instead.

    Example:
        >>> TaskParams(max_torn_fraction=0.25).separated_fraction
        0.95
    """

    separated_fraction: float = 0.95
    max_torn_fraction: float = 0.5
    clear_distance_m: float = 0.05
    knife_stop_force_n: float = 35.0
    pull_stop_force_n: float = 80.0
    cycle_time_fails: bool = True

    def __post_init__(self) -> None:
        require_positive(self, "separated_fraction", "max_torn_fraction", "knife_stop_force_n",
                         "pull_stop_force_n")
        require_non_negative(self, "clear_distance_m")
        require_flag(self, "cycle_time_fails")
        for name in ("separated_fraction", "max_torn_fraction"):
            if getattr(self, name) > 1.0:
                raise InputError(None, name, f"must be in (0, 1], got {getattr(self, name)}")
