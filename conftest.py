"""Shared test set-up, for the tests and the docstring examples alike.

Headless rendering is chosen here (``MUJOCO_GL=egl`` unless set): MuJoCo reads the variable
at its own import, and pytest imports this file before any test module. The CAD parts'
decomposition cache goes to a folder of the test session's (``MUSCLECELL_CACHE_DIR``), never
the user's.
"""

import atexit
import os
import shutil
import tempfile
from collections.abc import Iterator

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ["MUSCLECELL_CACHE_DIR"] = tempfile.mkdtemp(prefix="musclecell-cache-")
atexit.register(shutil.rmtree, os.environ["MUSCLECELL_CACHE_DIR"], ignore_errors=True)


@pytest.fixture(autouse=True)
def _mujoco_warnings() -> Iterator[list[str]]:
    """Keep MuJoCo's warnings (such as a flex without elasticity) out of the MUJOCO_LOG.TXT
    its default handler writes."""
    import mujoco  # here, not above: MUJOCO_GL must be set first (module docstring)

    caught: list[str] = []
    mujoco.set_mju_user_warning(caught.append)
    yield caught
    mujoco.set_mju_user_warning(None)
