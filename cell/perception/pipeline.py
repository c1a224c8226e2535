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

The first part of the chain is one look of the camera (:func:`~cell.perception.look.look`),
starting the walk at a marker the camera sees (:func:`~cell.perception.look.marker_position`:
the only thing the chain takes from the true geometry); the truth is otherwise used only to
score the result. Its settings are :class:`~cell.perception.params.PerceptionParams`.

The knife follows the interface at depth as :class:`~cell.perception.interface.SeenInterface`
gives it: through the seen valley, leaning as the generic model until later looks into the
opened cut (:func:`~cell.perception.look.look`, between the passes of the cut) tell
otherwise. With ``interface = "affine"`` it follows
:class:`~cell.perception.predicted.PredictedInterface` instead: the fitted model's interface,
shifted along y onto the seen valley; a fit whose interface leans more than any muscle pair's
can (``max_interface_lean``) is refused then.

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
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from cell.errors import InputError
from cell.perception.curvature import Curvature
from cell.perception.guideline import CutPath
from cell.perception.interface import SeenInterface
from cell.perception.look import look, marker_position
from cell.perception.params import PerceptionParams
from cell.perception.pointcloud import SurfaceMesh
from cell.perception.predicted import PredictedInterface, refuse_leaning
from cell.perception.registration import (
    AffineFit,
    InterfacePrediction,
    fit_generic_model,
    predict_interface,
)
from cell.polyline import closest_on, length
from cell.robots.camera import CameraRig
from cell.tissue.geometry import MuscleShape, TwoMuscleMesh, build_two_muscles

#: A surface y(x, z) in world coordinates (m): the interface as the knife's plan takes it.
SurfaceY = Callable[[np.ndarray, np.ndarray], np.ndarray]


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
        interface_error_m: ``|predicted - true|`` interface y at the true interface's facing-pair
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
    """The generic model: the default :class:`~cell.tissue.shape.MuscleShape` (not the
    scenario's own, which stands for the real meat the robot does not know) where the fixture
    holds the meat, the middle of its interface at ``origin_m`` (world, m).

    Example:
        >>> generic_model((0.0, 0.0, 0.6)).origin_m
        array([0. , 0. , 0.6])
    """
    return build_two_muscles(MuscleShape(), origin_m=tuple(origin_m))


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
