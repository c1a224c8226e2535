"""The diagnosis of cut tests: a knife's force against the cut and along its edge.

Owns: ``causes`` (the cut catalogue), ``reduced`` (the reduced model of a cut), ``fitting``,
``search``, ``residuals`` (the trends a residual follows) and ``report``.
"""
