"""The one engine of every diagnosis: settings, the forward selection with its look-ahead,
backward drops and second look, the acceptance of a cause on held-out errors, and the rule that
a number about a fit is finite or said to be undetermined.

Owns: ``settings``, ``search``, ``acceptance``, ``determined``.
"""
