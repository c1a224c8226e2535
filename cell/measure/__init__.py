"""The lab's data, as files: what a lab measures and how it is written, MuJoCo-free.

Owns: ``specimens`` (specimen test sets: the specimen, its uniaxial tests, the reader and
writer), ``cuts`` (cut tests: block, blade, edge path and force), ``testrows`` (the rows of a
set's ``tests.csv``), ``protocols`` (the test protocols a set is drawn up from) and ``logs``
(the separation-log format: channels, frames, reader and schema, docs/log-format.md).
May import: the base modules of :mod:`cell` only.
"""
