"""musclecell: a MuJoCo simulation of the robot cell that separates two beef muscles.

Importing the package selects headless rendering (EGL through Mesa or a GPU driver) unless
``MUJOCO_GL`` is already set; MuJoCo reads it at its own import.
"""

import os

os.environ.setdefault("MUJOCO_GL", "egl")
