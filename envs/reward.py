"""One step's reward from the readings before and after it (see :class:`RewardParams`)."""

from __future__ import annotations

from envs.observation import Reading
from envs.params import RewardParams


def reward_terms(params: RewardParams, before: Reading, after: Reading, torn: float,
                 cut_advance: float, policy_cutting: bool = False,
                 clear_advance: float = 0.0) -> dict[str, float]:
    """The reward's terms for a step that led from ``before`` to ``after``, tore the fraction
    ``torn`` of the bindings, moved the knife ``cut_advance`` (fraction of its path) along
    and the shank ``clear_advance`` (fraction of the task's clearing distance) away, the
    policy's knife not yet through if ``policy_cutting``; the reward is their sum (costs are
    negative).

    Example:
        >>> import numpy as np
        >>> zero = np.zeros(3)
        >>> before = Reading(zero, 0.01, np.eye(3), zero, zero, zero, zero, released_fraction=0.5,
        ...                  released_ahead=0.0, strain_near=0.0, strain_max=0.0,
        ...                  blade_contacts=0, under_blade=0, interface_offset_m=0.0)
        >>> from dataclasses import replace
        >>> after = replace(before, released_fraction=0.52)
        >>> terms = reward_terms(RewardParams(), before, after, torn=0.0, cut_advance=0.01)
        >>> " ".join(sorted(terms))
        'clearing cut_progress damage force progress tearing time uncut_depth'
        >>> terms["damage"], terms["force"], terms["uncut_depth"]
        (-0.0, -0.0, -0.0)
        >>> round(reward_terms(RewardParams(), before, after, 0.0, 0.01, policy_cutting=True
        ...                    )["uncut_depth"], 4)  # 10 mm up, 7 mm above the reach
        -0.021
    """
    touching = after.blade_contacts > 0
    damage = params.contact_per_step if after.blade_in_flesh else 0.0
    if touching:
        damage += params.off_interface_per_m * max(
            0.0, after.interface_offset_m - params.interface_tolerance_m)
    force = min(params.force_cap_per_step, params.force_per_n * (
        max(0.0, after.knife_force_magnitude_n - params.knife_force_limit_n)
        + max(0.0, after.pull_force_magnitude_n - params.pull_force_limit_n)))
    uncut = (params.uncut_depth_per_m * max(0.0, after.tip_height_m - params.cut_reach_m)
             if policy_cutting else 0.0)
    return {
        "progress": params.progress * (after.released_fraction - before.released_fraction),
        "cut_progress": params.cut_progress * cut_advance,
        "clearing": params.clearing * clear_advance,
        "damage": -damage,
        "force": -force,
        "tearing": -params.tearing * torn,
        "time": -params.time_per_step,
        "uncut_depth": -uncut,
    }
