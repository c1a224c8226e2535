"""Measured tissue tests and what they say about the material: the measured-data reader and
writer, the synthetic-set generator, the specimen solve, the catalogue of causes, the
diagnosis and its report.

Owns: ``measured`` (with ``cuts``, its cut tests, and ``testrows``), ``synthetic``,
``specimen``, ``causes``, ``settings``, ``diagnosis``, ``report``; for cut tests the reduced
model of a cut (``cutreduced``), its catalogue of causes (``cutcauses``), fits
(``cutfitting``), search (``cutsearch``), the diagnosis of a set of either kind or both
(``cutdiagnosis``) and its report (``cutreport``).
May import: the base modules of :mod:`cell` and the MuJoCo-free part of :mod:`cell.tissue`;
never MuJoCo, and the diagnosis never the synthetic generator (its answer key).
"""
