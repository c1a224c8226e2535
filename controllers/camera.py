"""The camera controller: where the camera arm holds the camera and what it looks at."""

from __future__ import annotations

import numpy as np

from cell.tissue.geometry import TwoMuscleMesh

#: Camera position relative to the meat's top centre (m): high above it, clear of the Vipers'
#: wrists, a little toward the camera arm.
VIEW_OFFSET_M = np.array([0.10, 0.05, 0.60])


def view_pose(mesh: TwoMuscleMesh) -> tuple[np.ndarray, np.ndarray]:
    """Camera eye and look-at point (world, m) that frame both muscles."""
    points = np.vstack([mesh.round.points, mesh.shank.points])
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    top = np.array([centre[0], centre[1], points[:, 2].max()])
    return top + VIEW_OFFSET_M, centre
