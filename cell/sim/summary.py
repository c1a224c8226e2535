"""What a scripted episode measures while it runs and the summary it reports at the end.

The summary splits into ``result`` (a function of the scenario and its seed alone) and
``timing`` (wall-clock figures of this run).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from cell.perception.pipeline import PerceivedPlan
from cell.profiling import timed
from cell.sim.assembly import Scene
from cell.sim.relook import Relooks
from cell.sim.scenario import Scenario
from cell.sim.score import CutScore
from cell.sim.simulation import Simulation
from cell.tissue.aponeurosis import Aponeurosis
from cell.tissue.geometry import TwoMuscleMesh
from controllers.knife import PassPlan
from controllers.steering import LeanSteering

#: Median gap (m) between facing vertices above which the muscles count as apart.
APART_GAP_M = 0.02


@dataclass
class EpisodeTrace:
    """What the episode's loop measures while it runs: per control step while the knife cuts
    (tracking error m, cutting force N, the load's parts N), per control step once the sensors
    are tared (forces N, torque N m), and the largest drift of each arm that should hold still
    (m).

    Example:
        >>> trace = EpisodeTrace()
        >>> trace.knife_force_n.append(3.0)
        >>> recording_scalars(trace, released_fraction=0.5)["forces/knife_n"]
        3.0
    """

    tracking_error_m: list[float] = field(default_factory=list)
    knife_force_n: list[float] = field(default_factory=list)
    cutting_force_n: list[float] = field(default_factory=list)
    knife_load_n: dict[str, list[float]] = field(default_factory=dict)
    knife_torque_nm: list[float] = field(default_factory=list)
    pull_force_n: list[float] = field(default_factory=list)
    fixture_force_n: list[float] = field(default_factory=list)
    held_drift_m: dict[str, float] = field(default_factory=dict)


def recording_scalars(trace: EpisodeTrace, released_fraction: float) -> dict[str, float]:
    """The latest figures of ``trace`` for the recording's plots, by stream name."""
    values = {"progress/released_fraction": released_fraction}
    for name, series in (("forces/knife_n", trace.knife_force_n),
                         ("forces/knife_torque_nm", trace.knife_torque_nm),
                         ("forces/pull_n", trace.pull_force_n),
                         ("forces/fixture_n", trace.fixture_force_n),
                         ("tracking/knife_error_m", trace.tracking_error_m)):
        if series:
            values[name] = series[-1]
    return values


def released_fraction(aponeurosis: Aponeurosis) -> float:
    """The fraction of the bindings released so far."""
    return float(1.0 - aponeurosis.bound.mean())


def _peak(series: list[float]) -> float:
    return float(max(series)) if series else 0.0


def _mean(series: list[float]) -> float:
    return float(np.mean(series)) if series else 0.0


@timed("summary")
def episode_summary(scenario: Scenario, scene: Scene, sim: Simulation, trace: EpisodeTrace,
                    score: CutScore, passes: PassPlan, wall_s: float,
                    perceived: PerceivedPlan | None, relooks: Relooks | None,
                    steering: LeanSteering | None) -> dict[str, Any]:
    """The episode's summary at its end: ``result`` (the cut, the forces, the tracking, the
    perception; SI units) and ``timing`` (wall-clock s)."""
    apo = scene.aponeurosis
    gap = apo.lengths(sim.data) - apo.rest_length_m
    released = released_fraction(apo)
    errors = np.array(trace.tracking_error_m) if trace.tracking_error_m else np.zeros(1)
    result = {
        "scenario": scenario.name,
        "seed": scenario.seed,
        "tissue_nodes": scene.node_count,
        "tissue_mesh": _mesh_figures(scene.mesh),
        "cad_parts": {key: part.figures() for key, part in scene.cad_parts.items()},
        "bindings": len(apo),
        "released_by_rule": apo.released_counts(),
        "released_fraction": released,
        "gap_m": {"median": float(np.median(gap)), "mean": float(gap.mean()),
                  "min": float(gap.min())},
        "muscles_apart": bool(released >= 0.95 and float(np.median(gap)) >= APART_GAP_M),
        "grasped_vertices": len(sim.grasped),
        "knife_force_peak_n": _peak(trace.knife_force_n),
        "knife_force_cutting_mean_n": _mean(trace.cutting_force_n),
        # While the knife cuts: bindings hooked on its edge, flesh pushing on the blade
        # (contacts), the edge's cutting resistance and the faces' friction in the cut.
        "knife_force_split_n": {part: {"peak": _peak(series), "mean": _mean(series)}
                                for part, series in trace.knife_load_n.items()},
        "knife_torque_peak_nm": _peak(trace.knife_torque_nm),
        "pull_force_peak_n": _peak(trace.pull_force_n),
        "fixture_force_peak_n": _peak(trace.fixture_force_n),
        "knife_tracking_error_m": {"median": float(np.median(errors)),
                                   "p95": float(np.percentile(errors, 95)),
                                   "max": float(errors.max())},
        "held_arm_drift_m": trace.held_drift_m,
        # Against the truth: the bound surface of the two muscles where it is now.
        "knife_tip_to_true_interface_m": score.tip_distance(),
        "flesh_damage": score.flesh_damage(),
        "passes": [{"pass": i, "depth_m": depth, "window_s": list(window)}
                   for i, (depth, window) in enumerate(zip(passes.depths_m, passes.windows_s,
                                                           strict=True))],
        "sim_time_s": sim.time_s,
    }
    if perceived is not None:
        distance = perceived.guideline_distance_m
        result["perception"] = {
            "guideline_to_true_top_line_xy_m": {"mean": distance.mean_m,
                                                "max": distance.max_m},
            "coverage_of_true_top_line": perceived.coverage,
            "fit_rms_m": perceived.fit.rms_m,
            "cut_depth_m": {"min": float(perceived.cut_depth_m.min()),
                            "max": float(perceived.cut_depth_m.max())},
            "updates": [] if relooks is None else relooks.updates,
        }
    if steering is not None and steering.params.enabled:
        result["steering"] = {"lean_change": steering.lean_change,
                              "lean_change_min": steering.extremes[0],
                              "lean_change_max": steering.extremes[1]}
    looks_s = [perceived.timings_s["total"]] if perceived is not None else []
    looks_s += [u["perception_s"] for u in ([] if relooks is None else relooks.updates)]
    timing = {"wall_time_s": wall_s, "real_time_factor": sim.time_s / wall_s,
              "perception_s": looks_s,
              "cad_parts": {key: part.timing() for key, part in scene.cad_parts.items()}}
    arms = {prefix: arm.summary() for prefix, arm in scenario.arms.cell_arms().items()}
    return {"result": result, "arms": arms, "timing": timing}


def _mesh_figures(mesh: TwoMuscleMesh) -> dict[str, Any]:
    """What the summary says of the muscles' mesh: its source (the scan's files or the
    procedural shape), size, worst element and the bound interface's area (m^2)."""
    return {"source": [Path(name).name for name in mesh.shape.surface_mesh] or "procedural",
            "nodes": mesh.node_count,
            "tets": len(mesh.round.tets) + len(mesh.shank.tets),
            "min_dihedral_deg": mesh.min_dihedral_deg,
            "interface_area_m2": mesh.interface_area_m2}
