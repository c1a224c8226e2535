"""Perception of the cut (paper Sec. 5): what the camera sees becomes the knife's guideline and
the hidden interface it follows at depth.

One call, :func:`perceive`, runs the chain on the rendered scene: capture a noisy depth image
(:func:`~cell.perception.pointcloud.capture`), bin it into a cloud and a surface mesh
(:func:`~cell.perception.pointcloud.depth_mesh`), estimate the curvature
(:func:`~cell.perception.curvature.surface_curvature`), walk the valley from the start point P0
(:func:`~cell.perception.guideline.find_cut_path`) and move the walk onto the valley's floor in
the unbinned cloud (:func:`~cell.perception.floor.find_floor`), fit the generic two-muscle
model to the cloud (:func:`~cell.perception.registration.fit_generic_model`) and map its
interface into the world (:func:`~cell.perception.registration.predict_interface`).

P0 is a marker the camera sees. In the real cell an operator (or a vision tag) marks the
valley at one end of the meat; in simulation the marker is the point of the generator's true
top line ``marker_inset_m`` (along it) in from its first (-x) end, and that is the only thing
the chain takes from the true geometry. The camera finds it by projecting it into the image
and reading the perceived depth there: it is seen when its pixel has a depth and that depth is
the marker's own within a tolerance (else it is out of view, behind something, or not on the
surface), and P0 is the marker's pixel ray at the perceived depth. The truth is otherwise used
only to score the result.

The knife follows the interface at depth as :class:`~cell.perception.interface.SeenInterface`
gives it: through the seen valley, leaning as the generic model until later looks into the
opened cut (:func:`look`, between the passes of the cut) tell otherwise. With ``interface =
"affine"`` it follows :class:`~cell.perception.predicted.PredictedInterface` instead: the
fitted model's interface, shifted along y onto the seen valley; a fit whose interface leans
more than any muscle pair's can (``max_interface_lean``) is refused then.

Example (on the coarse meat; 8 x 8 bins keep the example quick):
    >>> from cell.robots.names import CAMERA
    >>> from cell.sim.episode import Episode
    >>> from cell.sim.scenario import Scenario
    >>> from cell.tissue.geometry import MuscleShape
    >>> episode = Episode(Scenario(tissue=MuscleShape(cell_size_m=0.05)))  # camera on the meat
    >>> with CameraRig(episode.scene.model, CAMERA, 320, 240) as rig:
    ...     plan = perceive(rig, episode.sim.data, episode.scene.mesh,
    ...                     generic_model(episode.scenario.layout.meat_origin_m),
    ...                     PerceptionParams(bin_px=8), np.random.default_rng(0))
    >>> plan.guideline_distance_m.mean_m < 0.005, plan.coverage > 0.9
    (True, True)
    >>> sorted(plan.summary())
    ['fit', 'guideline', 'interface', 'mesh', 'timing_s']
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import mujoco
import numpy as np

from cell.config import require_count, require_flag
from cell.errors import InputError, PerceptionError
from cell.perception.curvature import Curvature, surface_curvature
from cell.perception.floor import FloorParams, find_floor
from cell.perception.guideline import CutPath, GuidelineParams, find_cut_path
from cell.perception.interface import SeenInterface
from cell.perception.pointcloud import DepthView, SensorNoise, SurfaceMesh, capture, depth_mesh
from cell.perception.predicted import PredictedInterface, refuse_leaning
from cell.perception.registration import (
    AffineFit,
    FitParams,
    InterfacePrediction,
    fit_generic_model,
    predict_interface,
)
from cell.polyline import closest_on, length, point_at
from cell.robots.camera import CameraRig
from cell.tissue.geometry import MuscleShape, TwoMuscleMesh, build_two_muscles

# The fewest cloud points the chain works with: the twelve the fit needs.
_MIN_CLOUD_POINTS = 12

#: A surface y(x, z) in world coordinates (m): the interface as the knife's plan takes it.
SurfaceY = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class PerceptionParams:
    """How the cut is perceived (SI units).

    Attributes:
        enabled: whether the episode plans the knife from this perception (True) or from the
            generator's true top line and interface (False, the ground-truth baseline); read by
            the caller, :func:`perceive` itself always perceives.
        noise_sigma_at_1m_m: depth noise at 1 m, m (see
        :class:`~cell.perception.pointcloud.SensorNoise`). dropout_fraction: fraction of pixels
        without depth, in [0, 1). bin_px: the depth image is binned this many pixels square before
        meshing; 4 on the
            default 320 x 240 camera gives about the paper's mesh (1376 nodes).
        curvature_radius_m: radius of the curvature ball.
        marker_inset_m: the start marker's distance along the true top line from its first
            (-x) end, m.
        marker_tolerance_m: the most the perceived depth at the marker's pixel may differ from
            the marker's own depth for the marker to count as seen, m.
        interface: how the interface below the guideline is estimated: ``"seen"``
            (:class:`~cell.perception.interface.SeenInterface`: through the seen guideline,
            leaning as the generic model until later looks into the opened cut tell, chosen by
            measurement) or ``"affine"`` (:class:`PredictedInterface`: the affine fit's
            interface shifted onto the guideline).
        max_interface_lean: the steepest lean |dy/dz| the fitted interface may have below the
            guideline (the generator's shapes keep within 0.5). A top view leaves the fit's
            shears of height into y nearly free, and on meat far from the generic shape the
            fit uses them: its interface then leans tens of degrees and the knife would cut
            into a muscle, so such a fit is refused.
        guideline: how the valley is walked (:class:`~cell.perception.guideline.GuidelineParams`).
        floor: where the walked guideline finds the valley's floor on the unbinned cloud
            (:class:`~cell.perception.floor.FloorParams`).
        fit: how the generic model is fitted (:class:`~cell.perception.registration.FitParams`).

    Raises:
        InputError: a field out of range; ``field`` names it.

    Example:
        >>> PerceptionParams(bin_px=2).noise
        SensorNoise(sigma_at_1m_m=0.0015, dropout_fraction=0.02)
    """

    enabled: bool = True
    noise_sigma_at_1m_m: float = 1.5e-3
    dropout_fraction: float = 0.02
    bin_px: int = 4
    curvature_radius_m: float = 0.015
    marker_inset_m: float = 0.02
    marker_tolerance_m: float = 0.005
    max_interface_lean: float = 0.5
    interface: Literal["seen", "affine"] = "seen"
    guideline: GuidelineParams = field(default_factory=GuidelineParams)
    floor: FloorParams = field(default_factory=FloorParams)
    fit: FitParams = field(default_factory=FitParams)

    def __post_init__(self) -> None:
        require_flag(self, "enabled")
        if not self.noise_sigma_at_1m_m >= 0.0:
            raise InputError(None, "noise_sigma_at_1m_m",
                             f"must be >= 0, got {self.noise_sigma_at_1m_m}")
        if not 0.0 <= self.dropout_fraction < 1.0:
            raise InputError(None, "dropout_fraction",
                             f"must be in [0, 1), got {self.dropout_fraction}")
        require_count(self, "bin_px", 1)
        for name in ("curvature_radius_m", "marker_tolerance_m", "max_interface_lean"):
            if not getattr(self, name) > 0.0:
                raise InputError(None, name, f"must be > 0, got {getattr(self, name)}")
        if not self.marker_inset_m >= 0.0:
            raise InputError(None, "marker_inset_m", f"must be >= 0, got {self.marker_inset_m}")
        if self.interface not in ("seen", "affine"):
            raise InputError(None, "interface",
                             f"must be 'seen' or 'affine', got {self.interface!r}")
        if not isinstance(self.guideline, GuidelineParams):
            raise InputError(None, "guideline", "must be a GuidelineParams")
        if not isinstance(self.floor, FloorParams):
            raise InputError(None, "floor", "must be a FloorParams")
        if not isinstance(self.fit, FitParams):
            raise InputError(None, "fit", "must be a FitParams")

    @property
    def noise(self) -> SensorNoise:
        """The sensor model these parameters describe."""
        return SensorNoise(self.noise_sigma_at_1m_m, self.dropout_fraction)


@dataclass(frozen=True)
class Deviation:
    """Mean and greatest of a set of distances, m.

    Example:
        >>> Deviation.of(np.array([0.001, 0.003])).max_m
        0.003
    """

    mean_m: float
    max_m: float

    @classmethod
    def of(cls, distances_m: np.ndarray) -> Deviation:
        """The mean and the maximum of ``distances_m`` (non-empty), m."""
        return cls(float(np.mean(distances_m)), float(np.max(distances_m)))


@dataclass(frozen=True, eq=False)
class PerceivedPlan:
    """Everything the camera gave towards the cut, world frame.

    Attributes:
        cloud_m: (N, 3) the binned point cloud, m.
        mesh: the surface mesh of the binned depth grid.
        curvature: per-vertex curvature of ``mesh`` (``curvature.mean_1_m``: mean, 1/m).
        marker_m: (3,) the start marker as the camera sees it, m.
        guideline: the cut guideline on the surface (points, tangents, normals, nodes).
        fit: the generic model's fitted twelve parameters.
        interface: the interface the fit predicts, sampled at the model's facing pairs.
        interface_y: the interface as y(x, z) through the guideline, for
            :func:`controllers.knife.plan_cut`: a
            :class:`~cell.perception.interface.SeenInterface` or, with ``interface =
            "affine"``, the fit's :class:`PredictedInterface`.
        timings_s: wall time of each stage (capture, mesh, curvature, guideline, fit,
            predict), s.
        guideline_distance_m: plan-view (xy) distance of the guideline's samples to the
            generator's true top line, None without the truth.
        coverage: the guideline's length over the true top line's length, None without the
            truth.
        interface_error_m: |predicted - true| interface y at the true interface's facing-pair
            midpoints (table to top, end to end), None without the truth.

    :func:`perceive` returns one; the module's example shows it.
    """

    cloud_m: np.ndarray
    mesh: SurfaceMesh
    curvature: Curvature
    marker_m: np.ndarray
    guideline: CutPath
    fit: AffineFit
    interface: InterfacePrediction
    interface_y: SurfaceY
    timings_s: Mapping[str, float]
    guideline_distance_m: Deviation | None = None
    coverage: float | None = None
    interface_error_m: Deviation | None = None

    @property
    def cut_depth_m(self) -> np.ndarray:
        """(K,) how deep the cut must reach below each guideline sample to part the muscles
        (:meth:`~cell.perception.registration.InterfacePrediction.depth_below`), m."""
        return self.interface.depth_below(self.guideline.points_m)

    def summary(self) -> dict[str, Any]:
        """The plan's figures as JSON-ready values (SI units; rotation as a rotation vector,
        rad; translation about the generic model's centroid ``pivot_m``; S of A = R S as three
        scales and three shears ``(S_xy, S_xz, S_yz)``)."""
        fit, path = self.fit, self.guideline
        scale_shear = fit.scale_shear
        depth = self.cut_depth_m

        def deviation(value: Deviation | None) -> dict[str, float] | None:
            return None if value is None else {"mean": value.mean_m, "max": value.max_m}

        return {
            "guideline": {
                "distance_to_true_top_line_xy_m": deviation(self.guideline_distance_m),
                "coverage_of_true_top_line": self.coverage,
                "length_m": path.length_m,
                "samples": len(path.points_m),
                "nodes": len(path.nodes),
                "start_m": self.marker_m.tolist(),
            },
            "fit": {
                "rotation_vector_rad": fit.rotation_vector_rad.tolist(),
                "translation_m": fit.translation_m.tolist(),
                "scales": np.diag(scale_shear).tolist(),
                "shears": scale_shear[np.triu_indices(3, 1)].tolist(),
                "pivot_m": fit.pivot_m.tolist(),
                "rms_m": fit.rms_m,
            },
            "interface": {
                "y_error_m": deviation(self.interface_error_m),
                "cut_depth_m": {"min": float(depth.min()), "mean": float(depth.mean()),
                                "max": float(depth.max()), "along_path": depth.tolist()},
            },
            "mesh": {"nodes": len(self.mesh.vertices_m),
                     "triangles": len(self.mesh.triangles),
                     "cloud_points": len(self.cloud_m)},
            "timing_s": dict(self.timings_s),
        }


def generic_model(origin_m: tuple[float, float, float] | np.ndarray) -> TwoMuscleMesh:
    """The generic model: the default :class:`~cell.tissue.geometry.MuscleShape` (not the
    scenario's own, which stands for the real meat the robot does not know) where the fixture
    holds the meat, the middle of its interface at ``origin_m`` (world, m).

    Example:
        >>> generic_model((0.0, 0.0, 0.6)).origin_m
        array([0. , 0. , 0.6])
    """
    return build_two_muscles(MuscleShape(), origin_m=tuple(origin_m))


def marker_position(truth: TwoMuscleMesh, inset_m: float) -> np.ndarray:
    """(3,) the simulated start marker: the point of ``truth``'s top line ``inset_m`` along it
    from its first (-x) end, m (its last point if the line is shorter).

    Example:
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


def _scores(truth: TwoMuscleMesh, guideline: CutPath, interface_y: SurfaceY
            ) -> dict[str, Any]:
    """The plan's scores against the generator's true meat: :class:`PerceivedPlan`'s
    ``guideline_distance_m``, ``coverage`` and ``interface_error_m``."""
    true_surface = truth.pair_midpoints_m
    return {
        "guideline_distance_m": Deviation.of(
            closest_on(guideline.points_m[:, :2], truth.top_line[:, :2]).distance_m),
        "coverage": guideline.length_m / length(truth.top_line),
        "interface_error_m": Deviation.of(np.abs(
            interface_y(true_surface[:, 0], true_surface[:, 2]) - true_surface[:, 1])),
    }


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


def perceive(
    rig: CameraRig,
    data: mujoco.MjData,
    truth: TwoMuscleMesh | None,
    generic: TwoMuscleMesh,
    params: PerceptionParams,
    rng: np.random.Generator,
    marker_m: np.ndarray | None = None,
) -> PerceivedPlan:
    """Find the cut guideline and the hidden interface from what ``rig`` sees of ``data``.

    Args:
        rig: the camera (its arm already framing the meat).
        data: the simulation state to look at (``mj_forward`` run on it).
        truth: the generator's true meat, for the marker and the scores; None to give
            ``marker_m`` and go without scores.
        generic: the model fitted to the cloud (:func:`generic_model`).
        params: the perception's parameters.
        rng: the sensor noise's random source (seed it for repeatable runs).
        marker_m: (3,) the start marker, m; by default :func:`marker_position` of ``truth``.

    Returns:
        The plan; ``interface_y`` goes to :func:`controllers.knife.plan_cut` with
        ``guideline.points_m`` as its path.

    Raises:
        PerceptionError: the camera sees no meat, too few points for the chain, the marker out
            of view or off the meat, no valley at it, or a fitted interface leaning more than
            ``max_interface_lean``: never a path then.
        InputError: neither ``truth`` nor ``marker_m`` given.
    """
    if marker_m is None:
        if truth is None:
            raise InputError(None, "marker_m", "is needed when the truth is not given")
        marker_m = marker_position(truth, params.marker_inset_m)
    seen = look(rig, data, params, rng, marker_m)
    timings = dict(seen.timings_s)
    clock = time.perf_counter()
    fit = fit_generic_model(seen.cloud_m, generic, params.fit)
    timings["fit"] = time.perf_counter() - clock
    clock = time.perf_counter()
    interface = predict_interface(fit, generic)
    guideline = seen.guideline
    interface_y: SurfaceY
    if params.interface == "affine":
        interface_y = PredictedInterface(fit, generic, guideline.points_m)
        refuse_leaning(interface_y, guideline.points_m, params.max_interface_lean)
    else:
        interface_y = SeenInterface((guideline.points_m,), generic.interface_y)
    timings["predict"] = time.perf_counter() - clock
    timings["total"] = sum(timings.values())
    scores = {} if truth is None else _scores(truth, guideline, interface_y)
    return PerceivedPlan(seen.cloud_m, seen.mesh, seen.curvature, seen.start_m, guideline, fit,
                         interface, interface_y, timings, **scores)
