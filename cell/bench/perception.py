"""``musclecell bench perception``: speed and accuracy of the perception chain on the default
cell, each speed beside peers measured in the same run.

Entries (``value`` in ``unit``; where a peer applies, ``peer`` in the same unit and
``ratio`` = value / peer, so below 1 means ours is faster):

- ``curvature_guideline_ms``: our curvature and guideline on the 4 x 4 binned depth mesh of the
  default scene (about the paper's 1376 nodes and 2662 triangles); the paper's 378 ms (MATLAB,
  i7 2.4 GHz, not this run) is given as ``paper_ms``.
- ``curvature_vs_trimesh_mean_ms``, ``curvature_vs_trimesh_gaussian_ms``,
  ``curvature_vs_libigl_ms``: our curvature alone against trimesh's
  ``discrete_mean_curvature_measure`` (it needs ``rtree``) and
  ``discrete_gaussian_curvature_measure`` at every vertex with the same ball radius, and
  libigl's ``principal_curvature`` with a ball of the same radius in mean edge lengths (at
  least 2, its minimum). A peer that is not installed is reported with ``skipped`` and no
  ratio.
- ``scaling_4x_ms``, ``scaling_16x_ms``: curvature and guideline on the same mesh subdivided
  once and twice (each triangle into four; the surface and its noise stay those of the 4 x 4
  mesh, so only the size changes; finer binning would add the noise of smaller bins);
  peer: the 1x mesh; the trimesh and libigl times at that size come along.
- ``guideline_mean_distance_m``, ``guideline_max_distance_m``: the worst over seeds of the
  guideline's plan-view distance to the true top line (mean, max), sensor noise on; targets
  5 mm and 15 mm.
- ``fit_recovery_vertex_error_m``, ``fit_recovery_rotation_deg``: a known random twelve-
  parameter transform applied to the noiseless cloud, recovered by the fit (the worst over
  trials of the model vertices' error and of the rotation's); targets 1 mm and 1 degree.
- ``perceive_ms``: the whole chain, capture to interface, median over the seeds, with stages;
  target 300 ms (an update between passes must not hold the cell up).
- ``interface_y_error_other_shape_m``: how far the predicted interface lies from the true one
  on meat of another shape than the generic model's (the fit's honest test), mean and max.

With ``shapes`` > 0 the report also holds ``shapes``: the scenario's whole episode on that many
shapes drawn from the documented ranges (:func:`~cell.bench.shapes.bench_shapes`; seeds from
``shape_seed``, by default 5000, which no test uses), a row per shape.
"""

from __future__ import annotations

import platform
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from cell.bench.parts import Progress, measured
from cell.bench.shapes import bench_shapes
from cell.perception.curvature import surface_curvature
from cell.perception.guideline import find_cut_path
from cell.perception.params import PerceptionParams
from cell.perception.pipeline import generic_model, perceive
from cell.perception.pointcloud import SurfaceMesh, capture
from cell.perception.registration import AffineFit, fit_generic_model, model_surface
from cell.robots.camera import CameraRig
from cell.robots.names import CAMERA
from cell.sim.episode import Episode
from cell.sim.scenario import Scenario, load_scenario
from cell.tissue.geometry import MuscleShape

#: The paper's time for curvature and guideline on 1376 nodes (MATLAB, i7 2.4 GHz).
PAPER_CURVATURE_GUIDELINE_MS = 378.0
#: Targets of the guideline (plan-view distance to the true top line) and of the fit.
GUIDELINE_MEAN_TARGET_M = 0.005
GUIDELINE_MAX_TARGET_M = 0.015
PERCEIVE_TARGET_MS = 300.0
#: The first seed of the shapes the episodes run on (no test draws from 5000 on).
SHAPE_SEED = 5000
FIT_VERTEX_TARGET_M = 0.001
FIT_ROTATION_TARGET_DEG = 1.0
#: Meat of another shape than the generic model's: bow, lean, height and length all differ.
OTHER_SHAPE = MuscleShape(interface_bow_m=0.03, interface_lean=0.2, round_height_m=0.105,
                          length_m=0.42)


def _median_ms(run: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return float(np.median(times)) * 1e3


def _peer_times_ms(mesh: SurfaceMesh, radius_m: float, repeats: int) -> dict[str, Any]:
    """Times of the trimesh and libigl curvatures on ``mesh``, ms; the reason instead where
    the library is missing."""
    times: dict[str, Any] = {}
    shape = trimesh.Trimesh(mesh.vertices_m, mesh.triangles, process=False)
    try:
        import rtree  # noqa: F401  (the mean curvature measure searches an R-tree of faces)
    except ImportError:
        times["trimesh_mean"] = "rtree not installed (trimesh's mean curvature measure needs it)"
    else:
        times["trimesh_mean"] = _median_ms(
            lambda: trimesh.curvature.discrete_mean_curvature_measure(
                shape, mesh.vertices_m, radius_m), repeats)
    times["trimesh_gaussian"] = _median_ms(
        lambda: trimesh.curvature.discrete_gaussian_curvature_measure(
            shape, mesh.vertices_m, radius_m), repeats)
    try:
        import igl
    except ImportError:
        times["libigl"] = "libigl not installed"
    else:
        corners = mesh.vertices_m[mesh.triangles]
        mean_edge = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).mean()
        edges = max(2, round(radius_m / mean_edge))
        times["libigl"] = _median_ms(lambda: igl.principal_curvature(
            mesh.vertices_m, mesh.triangles, edges, False), repeats)
    return times


def _peer_entry(ours_ms: float, peer: Any, name: str, mesh: SurfaceMesh) -> dict[str, Any]:
    entry: dict[str, Any] = {"value": ours_ms, "unit": "ms", "peer_name": name,
                             "nodes": len(mesh.vertices_m), "triangles": len(mesh.triangles)}
    if isinstance(peer, str):
        return entry | {"peer": None, "ratio": None, "skipped": peer}
    return entry | {"peer": peer, "ratio": ours_ms / peer}


def _ours_ms(mesh: SurfaceMesh, start_m: np.ndarray, radius_m: float, repeats: int
             ) -> tuple[float, float]:
    """Median times of our curvature alone and of curvature with the guideline, ms; both
    from the same runs, so that the second is never below the first."""
    curvature_s, both_s = [], []
    for _ in range(repeats):
        start = time.perf_counter()
        curvature = surface_curvature(mesh, radius_m)
        middle = time.perf_counter()
        find_cut_path(mesh, curvature, start_m)
        curvature_s.append(middle - start)
        both_s.append(time.perf_counter() - start)
    return float(np.median(curvature_s)) * 1e3, float(np.median(both_s)) * 1e3


def bench_curvature(mesh: SurfaceMesh, start_m: np.ndarray, radius_m: float,
                    repeats: int) -> dict[str, dict[str, Any]]:
    """Our curvature (and guideline from ``start_m``) against the peers on ``mesh`` and its
    subdivisions."""
    curvature_ms, both_ms = _ours_ms(mesh, start_m, radius_m, repeats)
    peers = _peer_times_ms(mesh, radius_m, max(1, repeats // 5))
    entries = {
        "curvature_guideline_ms": {
            "value": both_ms, "unit": "ms", "curvature_ms": curvature_ms,
            "nodes": len(mesh.vertices_m), "triangles": len(mesh.triangles),
            "paper_ms": PAPER_CURVATURE_GUIDELINE_MS},
        "curvature_vs_trimesh_mean_ms": _peer_entry(
            curvature_ms, peers["trimesh_mean"], "trimesh discrete_mean_curvature_measure", mesh),
        "curvature_vs_trimesh_gaussian_ms": _peer_entry(
            curvature_ms, peers["trimesh_gaussian"],
            "trimesh discrete_gaussian_curvature_measure", mesh),
        "curvature_vs_libigl_ms": _peer_entry(
            curvature_ms, peers["libigl"], "libigl principal_curvature", mesh),
    }
    vertices, triangles = mesh.vertices_m, mesh.triangles
    for factor in (4, 16):
        vertices, triangles = trimesh.remesh.subdivide(vertices, triangles)
        finer = SurfaceMesh(vertices, triangles)
        finer_curvature_ms, finer_ms = _ours_ms(finer, start_m, radius_m, max(1, repeats // 5))
        entries[f"scaling_{factor}x_ms"] = {
            "value": finer_ms, "unit": "ms", "peer": both_ms, "peer_name": "the 1x mesh",
            "ratio": finer_ms / both_ms, "curvature_ms": finer_curvature_ms,
            "nodes": len(vertices), "triangles": len(triangles),
            "peers_ms": _peer_times_ms(finer, radius_m, 1),
            "refinement": "trimesh.remesh.subdivide (each triangle into four)"}
    return entries


def _random_transform(rng: np.random.Generator, pivot_m: np.ndarray) -> AffineFit:
    """A rotation of 2 to 5 degrees about a random axis, translations up to 2 cm, scales 0.9 to
    1.1 and shears up to 0.05: the spread of a real piece of meat about the nominal one."""
    axis = rng.normal(size=3)
    rotation = Rotation.from_rotvec(axis / np.linalg.norm(axis) * np.radians(rng.uniform(2, 5)))
    scale_shear = np.diag(rng.uniform(0.9, 1.1, 3))
    scale_shear[np.triu_indices(3, 1)] = rng.uniform(-0.05, 0.05, 3)
    return AffineFit(rotation.as_matrix() @ scale_shear, rng.uniform(-0.02, 0.02, 3), pivot_m,
                     0.0)


def bench_fit_recovery(cloud_m: np.ndarray, episode: Episode, trials: int
                       ) -> dict[str, dict[str, Any]]:
    """Recover known transforms T of the noiseless ``cloud_m``: the fit to T(cloud) against T
    after the fit to the cloud itself (so the rendering's own small offsets cancel)."""
    generic = generic_model(episode.scenario.layout.meat_origin_m)
    vertices = model_surface(generic).vertices_m
    base = fit_generic_model(cloud_m, generic)
    rng = np.random.default_rng(2015)
    vertex_errors, angles = [], []
    for _ in range(trials):
        moved = _random_transform(rng, base.pivot_m)
        fit = fit_generic_model(moved.apply(cloud_m), generic)
        expected = moved.apply(base.apply(vertices))
        vertex_errors.append(float(np.linalg.norm(fit.apply(vertices) - expected, axis=1).max()))
        truth = AffineFit(moved.matrix @ base.matrix, np.zeros(3), base.pivot_m, 0.0)
        angles.append(float(np.degrees(np.linalg.norm(
            Rotation.from_matrix(fit.rotation.T @ truth.rotation).as_rotvec()))))
    return {
        "fit_recovery_vertex_error_m": {
            "value": max(vertex_errors), "unit": "m", "target": FIT_VERTEX_TARGET_M,
            "pass": max(vertex_errors) <= FIT_VERTEX_TARGET_M, "trials": vertex_errors,
            "cloud_points": len(cloud_m)},
        "fit_recovery_rotation_deg": {
            "value": max(angles), "unit": "deg", "target": FIT_ROTATION_TARGET_DEG,
            "pass": max(angles) <= FIT_ROTATION_TARGET_DEG, "trials": angles},
    }


def bench_guideline(episode: Episode, rig: CameraRig, seeds: range
                    ) -> dict[str, dict[str, Any]]:
    """The whole chain with sensor noise, once per seed: guideline distances and times."""
    generic = generic_model(episode.scenario.layout.meat_origin_m)
    runs = []
    for seed in seeds:
        plan = perceive(rig, episode.sim.data, episode.scene.mesh, generic, PerceptionParams(),
                        np.random.default_rng(seed))
        runs.append({"seed": seed, "mean_m": plan.guideline_distance_m.mean_m,
                     "max_m": plan.guideline_distance_m.max_m, "coverage": plan.coverage,
                     "timings_s": dict(plan.timings_s)})
    worst_mean = max(run["mean_m"] for run in runs)
    worst_max = max(run["max_m"] for run in runs)
    stages = {stage: float(np.median([run["timings_s"][stage] for run in runs])) * 1e3
              for stage in runs[0]["timings_s"]}
    per_seed = [{k: v for k, v in run.items() if k != "timings_s"} for run in runs]
    return {
        "guideline_mean_distance_m": {
            "value": worst_mean, "unit": "m", "target": GUIDELINE_MEAN_TARGET_M,
            "pass": worst_mean <= GUIDELINE_MEAN_TARGET_M, "distance": "plan view (xy)",
            "seeds": per_seed},
        "guideline_max_distance_m": {
            "value": worst_max, "unit": "m", "target": GUIDELINE_MAX_TARGET_M,
            "pass": worst_max <= GUIDELINE_MAX_TARGET_M, "distance": "plan view (xy)"},
        "perceive_ms": {"value": stages["total"], "unit": "ms", "target": PERCEIVE_TARGET_MS,
                        "pass": stages.pop("total") <= PERCEIVE_TARGET_MS,
                        "stages_ms": stages},
    }


def bench_other_shape(scenario: Scenario, seed: int) -> dict[str, Any]:
    """The predicted interface's error on meat of :data:`OTHER_SHAPE`."""
    other = replace(scenario, tissue=OTHER_SHAPE)  # the implicit step needs no shorter step
    episode = Episode(other)
    with CameraRig(episode.scene.model, CAMERA, other.camera.width_px,
                   other.camera.height_px) as rig:
        plan = perceive(rig, episode.sim.data, episode.scene.mesh,
                        generic_model(other.layout.meat_origin_m), PerceptionParams(),
                        np.random.default_rng(seed))
    return {"value": plan.interface_error_m.mean_m, "unit": "m",
            "max_m": plan.interface_error_m.max_m,
            "guideline_distance_m": {"mean": plan.guideline_distance_m.mean_m,
                                     "max": plan.guideline_distance_m.max_m},
            "shape": {"interface_bow_m": OTHER_SHAPE.interface_bow_m,
                      "interface_lean": OTHER_SHAPE.interface_lean,
                      "round_height_m": OTHER_SHAPE.round_height_m,
                      "length_m": OTHER_SHAPE.length_m}}


def run_perception_bench(scenario_path: str | Path, quick: bool = False, shapes: int = 0,
                         shape_seed: int = SHAPE_SEED, progress: Progress = None
                         ) -> dict[str, Any]:
    """Run every entry on the scenario's cell, and the episode on ``shapes`` documented shapes
    from seed ``shape_seed`` on (``progress`` hears of each part and shape as it finishes);
    returns the JSON-ready report."""
    scenario = load_scenario(scenario_path)
    episode = Episode(scenario)
    params = PerceptionParams()
    with CameraRig(episode.scene.model, CAMERA, scenario.camera.width_px,
                   scenario.camera.height_px) as rig:
        def curvature() -> dict[str, Any]:
            plan = perceive(rig, episode.sim.data, episode.scene.mesh,
                            generic_model(scenario.layout.meat_origin_m), params,
                            np.random.default_rng(0))
            return bench_curvature(plan.mesh, plan.marker_m, params.curvature_radius_m,
                                   5 if quick else 20)

        def fit_recovery() -> dict[str, Any]:
            noiseless = capture(rig, episode.sim.data).points_m(params.bin_px)
            return bench_fit_recovery(noiseless, episode, 1 if quick else 3)

        parts = measured({"guideline": lambda: bench_guideline(episode, rig,
                                                               range(3 if quick else 5)),
                          "curvature": curvature, "fit_recovery": fit_recovery,
                          "other_shape": lambda: bench_other_shape(scenario, 0)}, progress)
    entries = parts["guideline"] | parts["curvature"] | parts["fit_recovery"]
    entries["interface_y_error_other_shape_m"] = parts["other_shape"]
    report = {
        "scenario": str(scenario_path),
        "machine": {"python": platform.python_version(), "processor": platform.machine(),
                    "mujoco": mujoco.__version__, "trimesh": trimesh.__version__},
        "entries": entries,
    }
    if shapes > 0:
        report["shapes"] = bench_shapes(scenario, range(shape_seed, shape_seed + shapes),
                                        progress)
    return report
