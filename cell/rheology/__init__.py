"""Measured tissue tests and what they say about the material: the measured-data reader and
writer, the synthetic-set generator, the specimen solve, the catalogue of causes, the
diagnosis and its report.

Owns: ``measured``, ``synthetic``, ``specimen``, ``causes``, ``diagnosis``, ``report``.
May import: the base modules of :mod:`cell` and the MuJoCo-free part of :mod:`cell.tissue`;
never MuJoCo, and the diagnosis never the synthetic generator (its answer key).
"""
