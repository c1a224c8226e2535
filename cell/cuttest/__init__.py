"""The full simulation of a cut test in MuJoCo: ``scene`` (the block, the blade and their
contact) and ``run`` (a cut test's edge path driven and its force read).

May import: the base modules of :mod:`cell`, :mod:`cell.robots`, :mod:`cell.tissue`,
:mod:`cell.measure` and :mod:`cell.sim`.
"""
