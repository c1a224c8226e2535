"""One episode of the cell: the scenario file, the cell assembled as one MuJoCo model, the
simulation step with its release rules and checks, the scripted episode, its score, recording,
log and picture.

Owns: ``scenario`` and ``scenariotoml``, ``assembly``, ``dynamometer``, ``simulation``,
``divergence``, ``relook``, ``episode``, ``score``, ``summary``, ``recording``,
``episodelog`` (the separation log an episode writes), ``picture``, ``examples`` (the shipped
scenarios), ``mujocolog`` and ``command`` (``musclecell run``, ``plan``, ``export-mjcf``,
``render``).
May import: :mod:`cell.robots`, :mod:`cell.tissue`, :mod:`cell.perception`,
:mod:`cell.measure`, :mod:`controllers`, and the base modules of :mod:`cell`.
"""
