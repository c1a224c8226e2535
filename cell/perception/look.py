"""One look of the camera at the meat (:func:`look`): a noisy depth image, its binned cloud,
surface mesh and curvature, and the guideline walked along the valley from the start marker
and moved onto the valley's floor.

P0 is a marker the camera sees. In the real cell an operator (or a vision tag) marks the
valley at one end of the meat; in simulation the marker is the point of the generator's true
top line ``marker_inset_m`` (along it) in from its first (-x) end (:func:`marker_position`),
and that is the only thing the chain takes from the true geometry. The camera finds it by
projecting it into the image and reading the perceived depth there: it is seen when its pixel
has a depth and that depth is the marker's own within a tolerance (else it is out of view,
behind something, or not on the surface), and P0 is the marker's pixel ray at the perceived
depth.

The first look starts :func:`~cell.perception.pipeline.perceive`; later ones, between the
passes of the cut, look into the opened valley (:mod:`cell.sim.relook`).

Example:
    >>> from cell.tissue.geometry import MuscleShape, build_two_muscles
    >>> marker_position(build_two_muscles(MuscleShape()), 0.02).round(3)
    array([-0.206, -0.011,  0.059])
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass

import mujoco
import numpy as np

from cell.errors import PerceptionError
from cell.perception.curvature import Curvature, surface_curvature
from cell.perception.floor import find_floor
from cell.perception.guideline import CutPath, find_cut_path
from cell.perception.params import PerceptionParams
from cell.perception.pointcloud import DepthView, SurfaceMesh, capture, depth_mesh
from cell.polyline import point_at
from cell.robots.camera import CameraRig
from cell.tissue.geometry import TwoMuscleMesh

# The fewest cloud points the chain works with: the twelve the fit needs.
_MIN_CLOUD_POINTS = 12


def marker_position(truth: TwoMuscleMesh, inset_m: float) -> np.ndarray:
    """(3,) the simulated start marker: the point of ``truth``'s top line ``inset_m`` along it
    from its first (-x) end, m (its last point if the line is shorter).

    Example:
        >>> from cell.tissue.geometry import MuscleShape, build_two_muscles
        >>> marker_position(build_two_muscles(MuscleShape()), 0.0)
        array([-0.225   , -0.014375,  0.05625 ])
    """
    return point_at(truth.top_line, inset_m)


def _seen_marker(view: DepthView, marker_m: np.ndarray, bin_px: int,
                 tolerance_m: float) -> np.ndarray:
    """The marker's pixel ray at the depth perceived there (the binned grid's, which has had
    the noise's median taken), m; PerceptionError where the camera does not see it."""
    height, width = view.depth_m.shape
    camera = view.rotation.T @ (np.asarray(marker_m, dtype=float) - view.position_m)
    depth = -camera[2]
    if not depth > 0.0:
        raise PerceptionError(f"the marker at {np.round(marker_m, 4).tolist()} m is behind "
                              "the camera")
    # The pinhole formula of cell.perception.pointcloud, solved for the pixel.
    u = round(view.focal_px * camera[0] / depth + width / 2.0 - 0.5)
    v = round(-view.focal_px * camera[1] / depth + height / 2.0 - 0.5)
    row, col = v // bin_px, u // bin_px
    if not (0 <= row < height // bin_px and 0 <= col < width // bin_px):
        raise PerceptionError(f"the marker at {np.round(marker_m, 4).tolist()} m is out of "
                              f"view: it projects to pixel ({u}, {v}) of {width} x {height}")
    seen = view.grid_points_m(bin_px)[row, col]
    seen_depth = float((seen - view.position_m) @ -view.rotation[:, 2])
    if not np.isfinite(seen_depth):
        raise PerceptionError(f"the camera does not see the marker at "
                              f"{np.round(marker_m, 4).tolist()} m: no meat at its pixel "
                              f"({u}, {v})")
    if abs(seen_depth - depth) > tolerance_m:
        raise PerceptionError(
            f"the camera does not see the marker at {np.round(marker_m, 4).tolist()} m: the "
            f"surface at its pixel is {seen_depth - depth:+.3f} m from it along the view "
            f"(tolerance {tolerance_m} m), so it is hidden or not on the meat")
    return view.position_m + view.rotation @ (camera * seen_depth / depth)


def _binned_cloud(view: DepthView, bin_px: int) -> np.ndarray:
    """(N, 3) the view's cloud binned ``bin_px`` square, m; PerceptionError when it has too
    few points for the chain."""
    cloud = view.points_m(bin_px)
    if len(cloud) < _MIN_CLOUD_POINTS:
        raise PerceptionError(
            f"the cloud has {len(cloud)} points after {bin_px} x {bin_px} binning; "
            f"the surface and the fit need at least {_MIN_CLOUD_POINTS}")
    return cloud


@dataclass(frozen=True, eq=False)
class Look:
    """One look of the camera at the meat: the cloud, its surface mesh and curvature, and the
    guideline walked along the valley from the start point (world frame, m).

    Attributes:
        cloud_m: (N, 3) the binned point cloud, m.
        mesh: the surface mesh of the binned depth grid.
        curvature: per-vertex curvature of ``mesh``.
        start_m: (3,) where the walk started: the marker's pixel ray at the seen depth, m.
        guideline: the valley's bottom line from there.
        timings_s: wall time of each stage (capture, mesh, curvature, guideline), s.

    :func:`look` returns one.
    """

    cloud_m: np.ndarray
    mesh: SurfaceMesh
    curvature: Curvature
    start_m: np.ndarray
    guideline: CutPath
    timings_s: Mapping[str, float]


def look(rig: CameraRig, data: mujoco.MjData, params: PerceptionParams,
         rng: np.random.Generator, marker_m: np.ndarray, marker_tolerance_m: float | None = None
         ) -> Look:
    """Capture a noisy depth image, mesh it, estimate its curvature and walk the valley from
    the marker (seen within ``marker_tolerance_m`` of its depth, by default the params'; the
    cut's opening may have taken the surface down at the marker since the first look).

    Raises:
        PerceptionError: as :func:`perceive`.
    """
    timings: dict[str, float] = {}
    clock = time.perf_counter()

    def lap(stage: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timings[stage] = now - clock
        clock = now

    tolerance = params.marker_tolerance_m if marker_tolerance_m is None else marker_tolerance_m
    view = capture(rig, data, params.noise, rng)
    cloud = _binned_cloud(view, params.bin_px)
    lap("capture")
    mesh = depth_mesh(view, params.bin_px)
    lap("mesh")
    curvature = surface_curvature(mesh, params.curvature_radius_m)
    lap("curvature")
    start = _seen_marker(view, marker_m, params.bin_px, tolerance)
    guideline = find_floor(find_cut_path(mesh, curvature, start, params.guideline),
                           view.points_m(1), params.floor)
    lap("guideline")
    return Look(cloud, mesh, curvature, start, guideline, timings)
