"""musclecell: a MuJoCo simulation of the robot cell that separates two beef muscles.

The library, bottom to top (each layer imports only those below it):

- ``errors``, ``io``, ``config``, ``collision``, ``polyline``: the base;
- ``robots``, ``tissue``: the machines and the meat;
- ``perception`` (uses both) and ``rheology`` (measured tests, the MuJoCo-free tissue);
- :mod:`controllers` (top-level package): mink IK and the cut and pull plans;
- ``sim``: scenario, assembled model, simulation, episode, recording;
- :mod:`envs` (top-level package): the Gymnasium envs;
- ``bench`` and ``cli`` on top.

Headless rendering: set ``MUJOCO_GL`` (``egl`` or ``osmesa``) before MuJoCo is imported;
``musclecell`` and the envs' renderer choose ``egl`` when it is unset.
"""
