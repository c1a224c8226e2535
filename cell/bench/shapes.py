"""Muscle shapes drawn from the documented ranges: the default randomisation's ``[shape.*]``
tables (``assets/randomization/default.toml``), one shape per seed.

The valley's width is left to the shape to derive (:attr:`MuscleShape.valley_decay_m`), as a
user who gives the other dimensions leaves it.

Example:
    >>> shape = documented_shape(1)
    >>> 0.40 <= shape.length_m <= 0.50, shape.valley_width_m is None
    (True, True)
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from cell.tissue.geometry import MuscleShape
from envs.randomization import Randomization, load_randomization

#: Shape fields the draw leaves to the shape's own derivation.
DERIVED_FIELDS = ("valley_width_m",)


def documented_shape(seed: int, base: MuscleShape | None = None,
                     randomization: Randomization | None = None) -> MuscleShape:
    """``base`` (the default shape) with every documented shape range drawn once from
    ``seed`` but :data:`DERIVED_FIELDS`.

    Raises:
        InputError: a drawn shape the checks refuse (the ranges are checked where they are
            loaded, so only a ``base`` outside them can).
    """
    randomization = load_randomization() if randomization is None else randomization
    rng = np.random.default_rng(seed)
    drawn = {}
    for key, distribution in randomization.entries:
        if key.startswith("shape."):
            drawn[key.removeprefix("shape.")] = float(distribution.sample(rng))
    kept = {name: value for name, value in drawn.items() if name not in DERIVED_FIELDS}
    return replace(MuscleShape() if base is None else base, **kept)
