"""Shared test set-up.

``import cell`` selects headless rendering (``MUJOCO_GL=egl`` unless set), but only if it runs
before MuJoCo's own import; pytest imports this file before any test module, whose imports put
``mujoco`` ahead of ``cell``.
"""

import cell  # noqa: F401
