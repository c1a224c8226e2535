"""The diagnosis of cut tests: a knife's force against the cut and along its edge.

Owns: ``causes`` (one module per cause, the registry, the cutting model), ``reduced`` (the
reduced model of a cut), ``fitting``, ``search`` (the family on the engine), ``residuals``
(the trends a residual follows) and ``report``.
"""
