"""Polylines: arc length along them, points at an arc length, and the closest points on them.

A polyline is an (N, D) array of points joined by straight segments, in m. One copy of these
few operations serves the perception (the marker on the true top line, the guideline's even
samples, the scores, the cut depth) and the knife (the cut's first fraction).

Example:
    >>> import numpy as np
    >>> from cell.polyline import arc_lengths, point_at
    >>> line = np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0], [0.3, 0.4, 0.0]])
    >>> arc_lengths(line)
    array([0. , 0.3, 0.7])
    >>> point_at(line, 0.5)
    array([0.3, 0.2, 0. ])
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Points closer than this (m) to the cut's end along the line are dropped by :func:`truncate`:
# the end point itself follows them, and a near-duplicate would give a zero-length segment.
_TRUNCATE_TOLERANCE_M = 1e-9


def segment_lengths(points_m: np.ndarray) -> np.ndarray:
    """(N - 1,) the lengths of the polyline's segments, m.

    Example:
        >>> import numpy as np
        >>> segment_lengths(np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 5.0]]))
        array([5., 1.])
    """
    return np.linalg.norm(np.diff(points_m, axis=0), axis=1)


def length(points_m: np.ndarray) -> float:
    """The polyline's length, m (the sum of its segments').

    Example:
        >>> import numpy as np
        >>> length(np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 5.0]]))
        6.0
    """
    return float(segment_lengths(points_m).sum())


def arc_lengths(points_m: np.ndarray) -> np.ndarray:
    """(N,) the arc length from the first point to each point, m (0 first).

    Example:
        >>> import numpy as np
        >>> arc_lengths(np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 5.0]]))
        array([0., 5., 6.])
    """
    return np.concatenate([[0.0], np.cumsum(segment_lengths(points_m))])


def point_at(points_m: np.ndarray, arc_m: float, arcs_m: np.ndarray | None = None) -> np.ndarray:
    """(D,) the point ``arc_m`` along the polyline from its first point, m; the end points
    past its ends. ``arcs_m`` is its :func:`arc_lengths` where the caller has them.

    Example:
        >>> import numpy as np
        >>> point_at(np.array([[0.0, 0.0], [3.0, 4.0]]), 2.5)
        array([1.5, 2. ])
    """
    arcs = arc_lengths(points_m) if arcs_m is None else arcs_m
    return np.array([np.interp(arc_m, arcs, points_m[:, k]) for k in range(points_m.shape[1])])


def truncate(points_m: np.ndarray, fraction: float) -> np.ndarray:
    """The polyline's first ``fraction`` (in [0, 1]) of arc length: the points before that
    arc length and the point at it, m.

    Example:
        >>> import numpy as np
        >>> truncate(np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]), 0.75)
        array([[0. , 0. ],
               [1. , 0. ],
               [1.5, 0. ]])
    """
    arcs = arc_lengths(points_m)
    end = fraction * arcs[-1]
    keep = arcs < end - _TRUNCATE_TOLERANCE_M
    return np.vstack([points_m[keep], point_at(points_m, end, arcs)])


@dataclass(frozen=True)
class Closest:
    """Where each of K points is closest to a polyline of N points.

    Attributes:
        segment: (K,) index i of the closest segment, from point i to point i + 1.
        fraction: (K,) how far along that segment the closest point lies, in [0, 1].
        distance_m: (K,) the distance to it, m.

    Example:
        >>> import numpy as np
        >>> line = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
        >>> closest_on(np.array([[0.25, 0.5], [2.0, 0.5]]), line)
        Closest(segment=array([0, 1]), fraction=array([0.25, 0.5 ]), distance_m=array([0.5, 1. ]))
    """

    segment: np.ndarray
    fraction: np.ndarray
    distance_m: np.ndarray


def closest_on(points_m: np.ndarray, line_m: np.ndarray) -> Closest:
    """The closest point on the polyline ``line_m`` (N, D) to each of ``points_m`` (K, D):
    its segment, the fraction along it and the distance, m. Give the first two coordinates of
    both for distances in the xy-plane.

    Example:
        >>> import numpy as np
        >>> closest_on(np.array([[0.5, 2.0]]), np.array([[0.0, 0.0], [1.0, 0.0]])).distance_m
        array([2.])
    """
    start, chord = line_m[:-1], np.diff(line_m, axis=0)
    offsets = points_m[:, None, :] - start
    along = np.clip(np.einsum("kij,ij->ki", offsets, chord) / np.sum(chord * chord, axis=1),
                    0.0, 1.0)
    distances = np.linalg.norm(offsets - along[..., None] * chord, axis=2)
    segment = np.argmin(distances, axis=1)
    rows = np.arange(len(points_m))
    return Closest(segment, along[rows, segment], distances[rows, segment])
