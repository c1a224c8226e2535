"""The hidden-effect generators and their answer keys, for benches and tests only.

Owns: ``specimen`` and ``truth`` (specimen sets with hidden causes, the laws that make them),
``cut`` (cut sets made by the full simulation of a cut) and ``logs`` (batches of separation
logs from changed worlds). Nothing outside :mod:`cell.synthetic`, :mod:`cell.bench` and the
tests imports it: a diagnosis never reads its answer key.
"""
