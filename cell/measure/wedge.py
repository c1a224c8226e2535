"""How a blade wedges its cut open (the cutting model's ``face_modulus_pa`` term): the blade's
half-thickness grows along the bevel from the edge's radius to half the spine's thickness, and
the cut's faces, each side a slab of the block strained in series, open by it.

Usage::

    strain = opening_strain(blade, block)      # at full opening
    opened = wedge_height_m(blade, height_m)   # the face's heights weighted by the opening
"""

from __future__ import annotations

import math

import numpy as np

from cell.measure.cuts import Blade, Block


def opening_strain(blade: Blade, block: Block) -> float:
    """The strain of the cut's faces where the blade opens them fully: its thickness over
    the block's extent across its plane (both sides of the cut strained in series).

    Example:
        >>> opening_strain(Blade(0.1, 0.002, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0)),
        ...                Block((0.04, 0.06, 0.03)))
        0.05
    """
    normal = np.abs(np.asarray(blade.blade_normal))
    return blade.thickness_m / float(normal @ np.asarray(block.size_m))


def wedge_height_m(blade: Blade, height_m: np.ndarray) -> np.ndarray:
    """How far the blade wedges the cut open over ``height_m`` of its face above the edge, as
    a height at full opening, m: the integral of the half-thickness
    ``min(r + s tan(bevel / 2), t / 2)`` over s from the edge, over ``t / 2``.

    Example:
        >>> blade = Blade(0.1, 0.002, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), 90.0, 0.0)
        >>> wedge_height_m(blade, np.array([0.0005, 0.003])).tolist()  # bevel 1 mm long
        [0.000125, 0.0025]
    """
    half = blade.thickness_m / 2
    slope = math.tan(math.radians(blade.bevel_deg) / 2)
    bevel = (half - blade.edge_radius_m) / slope
    s = np.clip(np.asarray(height_m, dtype=float), 0.0, None)
    on_bevel = np.minimum(s, bevel)
    opened = blade.edge_radius_m * on_bevel + 0.5 * slope * on_bevel ** 2 + half * (s - on_bevel)
    return opened / half
