"""The diagnosis of specimen tests (tension, compression, relaxation, cyclic).

Owns: ``causes`` (one module per cause, the registry, the candidate material), ``search``
(the family on the engine), ``solve`` (the homogeneous
specimen under load, with the muscles' springs), ``fitting``, ``intervals``, ``diagnosis``,
``repeats``, ``repeatsearch`` and ``spread`` (tests under equal conditions and the specimens'
variability), ``suggest`` and ``nexttests`` (the test to run next), ``plots`` and ``report``.
"""
