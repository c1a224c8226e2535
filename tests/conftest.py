"""Shared test set-up.

``import cell`` selects headless rendering (``MUJOCO_GL=egl`` unless set), but only if it runs
before MuJoCo's own import; pytest imports this file before any test module, whose imports put
``mujoco`` ahead of ``cell``.
"""

from collections.abc import Iterator

import pytest

import cell  # noqa: F401


@pytest.fixture(autouse=True)
def _mujoco_warnings() -> Iterator[list[str]]:
    """Keep MuJoCo's warnings (such as a flex without elasticity) out of the MUJOCO_LOG.TXT
    its default handler writes."""
    import mujoco  # here, not above: ``import cell`` must come first (module docstring)

    caught: list[str] = []
    mujoco.set_mju_user_warning(caught.append)
    yield caught
    mujoco.set_mju_user_warning(None)
