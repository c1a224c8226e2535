"""One episode of the cell: the scenario file, the cell assembled as one MuJoCo model, the
simulation step with its release rules and checks, the scripted episode and its recording.

Owns: ``scenario``, ``assembly``, ``simulation``, ``episode``, ``recording``.
May import: :mod:`cell.robots`, :mod:`cell.tissue`, :mod:`cell.perception`,
:mod:`controllers`, and the base modules of :mod:`cell`.
"""
