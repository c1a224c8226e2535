"""``musclecell bench``: speed and accuracy, as ratios against peers run side by side.

Owns: ``cell`` (the whole cell), ``tissue`` (the paper's Table 1; its models in
``tissue_variants``, its peers in ``tissue_peers``, its tension test in ``tissue_accuracy``),
``stability`` (the stable step search), ``timing``, ``perception``, ``env``, ``diagnose``.
May import: everything below it, :mod:`envs` included; nothing imports it but the CLI.
"""
