"""The separation task with one tool for the policy: the knife (:class:`CutEnv`) or the pull
(:class:`PullEnv`); the other tool follows the scripted plan."""

from __future__ import annotations

from typing import Any

from envs.params import TaskParams
from envs.separation import MuscleSeparationEnv
from envs.settings import CUT_TASK, PULL_KNIFE_CLEARANCE_M, PULL_TASK, parameters


class CutEnv(MuscleSeparationEnv):
    """Cut along the aponeurosis with the knife; the scripted pull keeps pace
    (``musclecell/Cut-v2``).

    .. rubric:: Description

    :class:`~envs.separation.MuscleSeparationEnv` with ``driven="knife"``: the policy drives
    the knife along the planned cut, whose clearance above the table differs from world to
    world (``cut_table_clearance_m`` is randomised) while the lowest bindings hold until the
    tip is close to the table: the policy takes the knife down by what it sees (the tip's
    height above the table and its depth below the path) and stops short of the table. The
    scripted pull follows the plan at the plan's time where the knife is, and pulls off once
    the knife is through.

    .. rubric:: Action space

    ``Box(-1, 1, (4,), float32)``: the knife's entries 0-3 of
    :class:`~envs.separation.MuscleSeparationEnv`'s action (along speed, across, depth,
    yaw).

    .. rubric:: Observation space

    :class:`~envs.separation.MuscleSeparationEnv`'s, all 35 entries.

    .. rubric:: Rewards

    :class:`~envs.separation.MuscleSeparationEnv`'s terms; ``uncut_depth`` counts from the
    hand-over until the knife is through, ``clearing`` is 0 (the task asks for no clearing
    distance).

    .. rubric:: Starting state

    As :class:`~envs.separation.MuscleSeparationEnv`'s: the knife in at the entry at depth.

    .. rubric:: Episode end

    As :class:`~envs.separation.MuscleSeparationEnv`'s under :data:`envs.settings.CUT_TASK`:
    success when the bindings are released with at most a quarter torn (no clearing
    distance: the scripted pull takes the shank away).

    .. rubric:: Arguments

    :class:`~envs.separation.MuscleSeparationEnv`'s but ``driven``; ``task`` (an object, or
    a mapping of fields over :data:`~envs.settings.CUT_TASK`).

    .. rubric:: Version history

    - v2: as ``MuscleSeparation-v2``'s: the knife meets the material's cutting model.
    - v1: as ``MuscleSeparation-v1``'s; seeded rollouts equal to v0's.
    - v0: the first version.

    Example:
        >>> import gymnasium, envs
        >>> env = gymnasium.make("musclecell/Cut-v2", cell_size_m=0.05)
        >>> env.action_space.shape
        (4,)
    """

    def __init__(self, **kwargs: Any) -> None:
        kwargs["task"] = parameters(TaskParams, kwargs.get("task"), "task", CUT_TASK)
        super().__init__(driven="knife", **kwargs)


class PullEnv(MuscleSeparationEnv):
    """Pull the shank away in pace with a scripted knife (``musclecell/Pull-v2``).

    .. rubric:: Description

    :class:`~envs.separation.MuscleSeparationEnv` with ``driven="pull"``: the knife follows
    its plan, which cuts :data:`~envs.settings.PULL_KNIFE_CLEARANCE_M` above the table (unless
    the options set ``cut_table_clearance_m``), at the world's ``knife_pace`` of the plan's
    speed (randomised: meat that slows the knife). A pull timed by the plan's clock pulls
    ahead of a slow knife and tears what it has not cut: the policy holds the shank while the
    knife cuts (its progress is in the observation) and takes it away once the knife is
    through.

    .. rubric:: Action space

    ``Box(-1, 1, (3,), float32)``: the pull's entries 4-6 of
    :class:`~envs.separation.MuscleSeparationEnv`'s action (the grasp site's displacement
    wanted, world x, y, z).

    .. rubric:: Observation space

    :class:`~envs.separation.MuscleSeparationEnv`'s, all 35 entries (the knife's are the
    scripted knife's).

    .. rubric:: Rewards

    :class:`~envs.separation.MuscleSeparationEnv`'s terms; ``uncut_depth`` is 0 (the knife
    is scripted), ``clearing`` pays the shank's distance up to the task's 5 cm once the knife
    is through.

    .. rubric:: Starting state

    As :class:`~envs.separation.MuscleSeparationEnv`'s: the jaws closed on the shank.

    .. rubric:: Episode end

    As :class:`~envs.separation.MuscleSeparationEnv`'s under :data:`envs.settings.PULL_TASK`:
    success when the bindings are released with at most a quarter torn and the shank taken
    5 cm away. The default time limit stretches the cut's part by the world's
    ``knife_pace``.

    .. rubric:: Arguments

    :class:`~envs.separation.MuscleSeparationEnv`'s but ``driven``; ``task`` (an object, or
    a mapping of fields over :data:`~envs.settings.PULL_TASK`); ``options`` holds
    ``cut_table_clearance_m`` = :data:`~envs.settings.PULL_KNIFE_CLEARANCE_M` unless given.

    .. rubric:: Version history

    - v2: as ``MuscleSeparation-v2``'s: the knife meets the material's cutting model.
    - v1: as ``MuscleSeparation-v1``'s; seeded rollouts equal to v0's.
    - v0: the first version.

    Example:
        >>> import gymnasium, envs
        >>> env = gymnasium.make("musclecell/Pull-v2", cell_size_m=0.05)
        >>> env.action_space.shape
        (3,)
    """

    def __init__(self, **kwargs: Any) -> None:
        kwargs["task"] = parameters(TaskParams, kwargs.get("task"), "task", PULL_TASK)
        kwargs["options"] = {"cut_table_clearance_m": PULL_KNIFE_CLEARANCE_M,
                             **(kwargs.get("options") or {})}
        super().__init__(driven="pull", **kwargs)
