"""The envs' Gymnasium ids, registered on ``import envs``.

:data:`CURRENT_IDS` are the four envs of this release; the older versions stay registered
for runs and policies made on them (the version history of each env's manual). ``-v2`` is the
current version: the knife meets the material's cutting model in the seam (the
scenario's ``aponeurosis.knife_force = "cutting"``). The ``-v1`` ids make the same envs with
the knife's force from the measured curve (``knife_force = "curve"``), as ``-v1`` did, so
their seeded rollouts stay what they were; the ``-v0`` ids of the release before stay one
release as aliases of ``-v1`` that warn.

Example:
    >>> import gymnasium
    >>> register_envs()
    >>> "musclecell/Cut-v2" in gymnasium.registry, "musclecell/Cut-v1" in gymnasium.registry
    (True, True)
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from typing import Any

from gymnasium.envs.registration import load_env_creator, register, registry

from envs.separation import MuscleSeparationEnv
from envs.settings import task_scenario

#: The envs by Gymnasium id, with their entry points.
ENV_IDS = {
    "musclecell/MuscleSeparation-v2": "envs.separation:MuscleSeparationEnv",
    "musclecell/Cut-v2": "envs.tasks:CutEnv",
    "musclecell/Pull-v2": "envs.tasks:PullEnv",
    "musclecell/MuscleSeparation-v1": "envs.separation:MuscleSeparationEnv",
    "musclecell/Cut-v1": "envs.tasks:CutEnv",
    "musclecell/Pull-v1": "envs.tasks:PullEnv",
    "musclecell/Steer-v2": "envs.steer:make_steer_v2",
    "musclecell/Steer-v1": "envs.steer:SteerEnv",
}
#: The current version of each env: what to train and evaluate on.
CURRENT_IDS = ("musclecell/MuscleSeparation-v2", "musclecell/Cut-v2", "musclecell/Pull-v2",
               "musclecell/Steer-v2")
#: Gymnasium's step bound of every id (``env.spec.max_episode_steps``, its ``TimeLimit``):
#: 50 s of 20 ms control steps, above every default time limit of the default randomisation
#: (``tests/envs/test_envs.py`` checks the longest: ``Pull``'s slowest scripted knife on the
#: longest meat), so the env's own time limit ends an episode first; a ``time_limit_s``
#: beyond it needs ``gymnasium.make(..., max_episode_steps=...)`` as well.
MAX_EPISODE_STEPS = 2500
#: The ids whose knife meets the measured cutting-force curve, as before the cutting model.
CURVE_IDS = frozenset({"musclecell/MuscleSeparation-v1", "musclecell/Cut-v1",
                       "musclecell/Pull-v1"})
#: The previous release's ids and the ids that replace them: v1 gives v0's seeded rollouts,
#: so an old id makes the new env, with a warning, until the next release removes it.
DEPRECATED_IDS = {
    "musclecell/MuscleSeparation-v0": "musclecell/MuscleSeparation-v1",
    "musclecell/Cut-v0": "musclecell/Cut-v1",
    "musclecell/Pull-v0": "musclecell/Pull-v1",
}


def make_with_curve(creator: Callable[..., MuscleSeparationEnv], **kwargs: Any
                    ) -> MuscleSeparationEnv:
    """The env ``creator`` makes, on its scenario (``scenario=``, default
    :func:`envs.settings.task_scenario`) with the knife's force from the measured curve.

    Example:
        >>> from envs.tasks import CutEnv
        >>> make_with_curve(CutEnv).base.aponeurosis.knife_force
        'curve'
    """
    scenario = kwargs.pop("scenario", None) or task_scenario()
    scenario = replace(scenario, aponeurosis=replace(scenario.aponeurosis, knife_force="curve"))
    return creator(scenario=scenario, **kwargs)


def env_creator(env_id: str) -> Callable[..., MuscleSeparationEnv]:
    """What makes the env of ``env_id`` (a key of :data:`ENV_IDS`) from ``gymnasium.make``'s
    keyword arguments, without Gymnasium's wrappers.

    Example:
        >>> env_creator("musclecell/Pull-v1")(time_limit_s=0.2).base.aponeurosis.knife_force
        'curve'
    """
    creator = load_env_creator(ENV_IDS[env_id])
    return partial(make_with_curve, creator) if env_id in CURVE_IDS else creator


def make_deprecated(old_id: str, new_id: str, **kwargs: Any) -> MuscleSeparationEnv:
    """The env of ``new_id`` for the old id ``old_id``, with a ``FutureWarning`` naming it.

    Example:
        >>> import pytest
        >>> with pytest.warns(FutureWarning, match="use musclecell/Cut-v1"):
        ...     env = make_deprecated("musclecell/Cut-v0", "musclecell/Cut-v1")
        >>> type(env).__name__
        'CutEnv'
    """
    warnings.warn(f"{old_id} is deprecated and goes in the next release: use {new_id}, the "
                  "same env under its new version", FutureWarning, stacklevel=2)
    return env_creator(new_id)(**kwargs)


def register_envs() -> None:
    """Register the envs with Gymnasium (once; importing :mod:`envs` does it)."""
    for env_id, entry_point in ENV_IDS.items():
        if env_id not in registry:
            register(id=env_id, entry_point=env_creator(env_id) if env_id in CURVE_IDS
                     else entry_point, disable_env_checker=False,
                     max_episode_steps=MAX_EPISODE_STEPS)
    for old_id, new_id in DEPRECATED_IDS.items():
        if old_id not in registry:
            register(id=old_id, entry_point=partial(make_deprecated, old_id, new_id),
                     disable_env_checker=False, max_episode_steps=MAX_EPISODE_STEPS)
