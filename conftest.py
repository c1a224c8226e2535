"""Shared test set-up, for the tests and the docstring examples alike.

Headless rendering is chosen here (``MUJOCO_GL=egl`` unless set): MuJoCo reads the variable
at its own import, and pytest imports this file before any test module.
"""

import os
from collections.abc import Iterator

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")


@pytest.fixture(autouse=True)
def _mujoco_warnings() -> Iterator[list[str]]:
    """Keep MuJoCo's warnings (such as a flex without elasticity) out of the MUJOCO_LOG.TXT
    its default handler writes."""
    import mujoco  # here, not above: MUJOCO_GL must be set first (module docstring)

    caught: list[str] = []
    mujoco.set_mju_user_warning(caught.append)
    yield caught
    mujoco.set_mju_user_warning(None)
