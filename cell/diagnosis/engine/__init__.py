"""The one engine of every diagnosis, knowing no family of causes: settings, the fits of a
search and the protocol a family implements, the forward selection with its look-ahead,
backward drops and second look, the acceptance of a cause on held-out errors, the statistics,
the evidence, and the rule that a number about a fit is finite or said to be undetermined.

Owns: ``settings``, ``fit`` (what the engine reads of a model and a fit), ``search``
(``Search``, ``Family``), ``selection``, ``acceptance``, ``statistics``, ``outcome``,
``determined``.
"""
