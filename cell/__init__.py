"""musclecell: a MuJoCo simulation of the robot cell that separates two beef muscles.

The library, bottom to top (each layer imports only those below it):

- ``errors``, ``io``, ``config``, ``outputs``, ``collision``, ``polyline`` and the other
  small modules beside them: the base;
- ``robots``, ``tissue`` and ``measure``: the machines, the meat, the lab's data formats;
- ``perception`` (uses robots and tissue), ``diagnosis`` (measured tests against the
  MuJoCo-free tissue) and ``robotlog`` (robot logs imported as measured data);
- :mod:`controllers` (top-level package): mink IK and the cut and pull plans;
- ``sim``: scenario, assembled model, simulation, episode, its score, recording and log;
- ``cuttest`` (the full simulation of a cut test), :mod:`envs` (top-level package: the
  Gymnasium envs) and ``logs`` (separation logs replayed and diagnosed);
- ``learning``, ``synthetic`` (the hidden-effect generators, for benches and tests),
  ``scale`` (Ray), then ``bench`` and ``cli`` on top;
- ``moved``: the old names of moved modules, for one release.

Headless rendering: set ``MUJOCO_GL`` (``egl`` or ``osmesa``) before MuJoCo is imported;
``musclecell`` and the envs' renderer choose ``egl`` when it is unset.
"""

from cell.moved import install as _install_moved

_install_moved()
