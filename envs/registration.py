"""The envs' Gymnasium ids, registered on ``import envs``; the ``-v0`` ids of the previous
release stay one release as aliases that warn.

Example:
    >>> import gymnasium
    >>> register_envs()
    >>> "musclecell/Cut-v1" in gymnasium.registry
    True
"""

from __future__ import annotations

import warnings
from functools import partial
from typing import Any

from gymnasium.envs.registration import load_env_creator, register, registry

from envs.separation import MuscleSeparationEnv

#: The envs by Gymnasium id, with their entry points.
ENV_IDS = {
    "musclecell/MuscleSeparation-v1": "envs.separation:MuscleSeparationEnv",
    "musclecell/Cut-v1": "envs.tasks:CutEnv",
    "musclecell/Pull-v1": "envs.tasks:PullEnv",
}
#: The previous release's ids and the ids that replace them: v1 gives v0's seeded rollouts,
#: so an old id makes the new env, with a warning, until the next release removes it.
DEPRECATED_IDS = {
    "musclecell/MuscleSeparation-v0": "musclecell/MuscleSeparation-v1",
    "musclecell/Cut-v0": "musclecell/Cut-v1",
    "musclecell/Pull-v0": "musclecell/Pull-v1",
}


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
    return load_env_creator(ENV_IDS[new_id])(**kwargs)


def register_envs() -> None:
    """Register the envs with Gymnasium (once; importing :mod:`envs` does it)."""
    for env_id, entry_point in ENV_IDS.items():
        if env_id not in registry:
            register(id=env_id, entry_point=entry_point, disable_env_checker=False)
    for old_id, new_id in DEPRECATED_IDS.items():
        if old_id not in registry:
            register(id=old_id, entry_point=partial(make_deprecated, old_id, new_id),
                     disable_env_checker=False)
