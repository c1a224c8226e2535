"""``musclecell bench``: speed and accuracy, as ratios against peers run side by side.

Owns: ``cell`` (the whole cell), ``tissue`` (the paper's Table 1), ``perception``, ``env``,
``diagnose``.
May import: everything below it, :mod:`envs` included; nothing imports it but the CLI.
"""
