"""What measured data say about the model: the diagnoses of specimen and cut tests.

Owns: ``engine`` (the selection of causes, their acceptance, held-out scores and the
undetermined numbers, shared by every family), ``specimen`` (the uniaxial causes, the specimen
solve, repeats and variability, the next test to run, the report), ``cut`` (the cut causes,
the reduced model of a cut, its fits, search and report), ``sets`` (a set of either kind or
both, diagnosed in one run) and ``command`` (``musclecell diagnose``). The separation logs'
diagnosis needs the simulation and lives in :mod:`cell.logs`.
May import: the base modules of :mod:`cell`, :mod:`cell.measure` and the MuJoCo-free part of
:mod:`cell.tissue`; never MuJoCo, never :mod:`cell.synthetic` (the answer key).
"""
