"""``musclecell bench tissue``: every tissue model on the two bound muscles, side by side.

Each model runs on the cell's two muscles without the robots (the scene of :func:`build_scene`
less the robots, ``build_scene(scenario, robots=False)``) and steps the cell's own physics
(:class:`~cell.sim.simulation.TissueSimulation`), with the aponeurosis as binding springs
and the shank standing on the table, at three mesh sizes. Per model and size it reports:

- ``us_per_node_step``: wall time of one step (the runtime's forces, then ``mj_step``) per
  tissue node, ``time.perf_counter``, best of three repetitions after a warm-up, the
  repetitions of all the runs of a size interleaved
  (:func:`~cell.bench.timing.best_step_times`); the same by
  the process's CPU time as ``cpu_us_per_node_step``, to tell a busy machine;
- ``stable_timestep_s``: the largest step that a short run from rest survives
  (:mod:`cell.bench.stability`: the simulation's own divergence check), capped; for the
  mass-spring models also :meth:`MassSpringModel.stable_timestep_s` (``safety=1``);
- ``real_time_factor``: simulated over wall time at ``run_timestep_s``: 0.9 times the stable
  step (the runtime's own safety factor) for MuJoCo's explicit step of the springs, the
  scenario's default step for the implicit one (:mod:`cell.tissue.implicit`);
- ``force_error_pct``: the realism figure, the reaction force of a tension test on a cube meshed
  at the same cell size, against the same model's converged force, extrapolated from three
  fine meshes (:mod:`cell.bench.tissue_accuracy`). Against its own limit,
  so that it measures what the mesh costs; how far the models' limits lie apart (model error:
  a spring lattice's fixed Poisson ratio, StVK against neo-Hookean) is in their reference
  forces;
- ``ratio_to_numpy``: ``us_per_node_step`` over that of a plain numpy mass-spring integrator
  measured in the same run on the same mesh
  (:class:`~cell.bench.tissue_peers.NumpyMassSpring`), the MATLAB-style peer.

Peers, timed the same way (:mod:`cell.bench.tissue_peers`): the numpy mass-spring, and MuJoCo's
stock flex (``<elasticity>``, bindings as ``connect`` equalities, MuJoCo's default solver
options).
The paper's Table 1 figures are carried as constants, not measured here. The targets (issue
14), their limits in :data:`US_PER_NODE_STEP_LIMITS` and :data:`REAL_TIME_FACTOR_LIMITS`: the
default meat's time per node and step at about 1000 nodes with the implicit step (the explicit
step's older, looser limit beside it), and at about 2000 nodes the real-time factor of
:func:`~cell.tissue.material.default_meat` and of the paper's Fig. 10 moduli (and its
D = 0.1 N s/m, :func:`~cell.bench.tissue_variants.paper_damping_s`), both with the implicit
step; the explicit step of both materials at its stable step is their peer. One thread:
MuJoCo has no thread pool here and the spring kernel is serial numba.

Example:
    >>> TissueBenchParams.quick().reference_cells
    (3, 4, 6)
"""

from __future__ import annotations

import os
import platform
import time
from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import mujoco

from cell.bench.tissue_accuracy import force_errors
from cell.bench.tissue_peers import stock_flex_run
from cell.bench.tissue_profile import step_profile
from cell.bench.tissue_timing import TissueBenchParams, time_runs, timing_steps
from cell.bench.tissue_variants import (
    bench_scenario,
    paper_damping_s,
    paper_fig10_material,
    tissue_run,
    tissue_variants,
)
from cell.cores import usable_cores
from cell.tissue.material import default_meat

#: The paper's Table 1 (Nabil et al. 2015, Core 2 Duo 3 GHz), wall time per node per iteration,
#: in microseconds. Quoted for comparison; NOT measured here.
PAPER_TABLE_1_US = {
    "mass_spring_matlab": 502.0,
    "mass_spring_sofa": 110.0,
    "tensor_mass_matlab": 430.0,
    "tensor_mass_sofa": 141.0,
}
#: The most wall time per node and step at about 1000 nodes, us, by step: the targets.
US_PER_NODE_STEP_LIMITS = {"explicit": 1.0, "implicit": 0.5}
#: The least real-time factor at about 2000 nodes with the implicit step, by material: the
#: targets.
REAL_TIME_FACTOR_LIMITS = {"default_meat": 2.0, "paper_fig10": 1.0}


def _bench_size(cell_size_m: float, params: TissueBenchParams,
                realism: dict[str, dict[str, Any]]) -> dict[str, Any]:
    models = tissue_variants()
    runs = {model.key: tissue_run(bench_scenario(model.material, cell_size_m,
                                                 model.tissue_step))
            for model in models}
    runs["mujoco_stock_flex"] = stock_flex_run(cell_size_m)
    meat = "mass_spring_nonlinear_anisotropic"
    entries = time_runs(runs, params, numpy_peer_of=meat)
    numpy_us = entries["numpy_mass_spring"]["us_per_node_step"]
    for key, entry in entries.items():
        if key != "numpy_mass_spring":
            entry["ratio_to_numpy"] = entry["us_per_node_step"] / numpy_us
    for model in models:
        entries[model.key] |= {"label": model.label, "family": model.family,
                               "tissue_step": model.tissue_step,
                               "force_error_pct":
                               realism[model.key]["force_error_pct"][str(cell_size_m)]}
    entries["mujoco_stock_flex"]["label"] = (
        "MuJoCo stock flex (StVK <elasticity>, connect bindings, defaults)")
    return {"cell_size_m": cell_size_m, "nodes": runs[meat].scene.node_count,
            "models": {model.key: entries[model.key] for model in models},
            "peers": {key: entries[key] for key in ("numpy_mass_spring", "mujoco_stock_flex")}}


def _targets(sizes: list[dict[str, Any]], realtime: dict[str, dict[str, Any]] | None
             ) -> dict[str, dict[str, Any]]:
    """The issue's three targets, each with its value, limit and verdict (None when the run
    did not reach the size it needs: ``--quick``)."""
    near = min(sizes, key=lambda size: abs(size["nodes"] - 1000))
    evaluated = abs(near["nodes"] - 1000) <= 200
    targets = {}
    for key, step in (("mass_spring_nonlinear_anisotropic", "explicit"),
                      ("mass_spring_nonlinear_anisotropic_implicit", "implicit")):
        limit = US_PER_NODE_STEP_LIMITS[step]
        us = near["models"][key]["us_per_node_step"] if evaluated else None
        targets[f"us_per_node_step_1000_nodes_{step}"] = {
            "what": f"non-linear anisotropic mass-spring, {step} step, two muscles, bindings, "
                    "table contact: us per node per step at about 1000 nodes",
            "nodes": near["nodes"] if evaluated else None, "value": us, "limit": limit,
            "pass": None if us is None else us <= limit}
    for material, what in (
            ("default_meat", "default meat, implicit step"),
            ("paper_fig10", "paper Fig. 10 (El = 0.25 MPa, Et = Er = 0.6 MPa), implicit step")):
        name, limit = f"real_time_{material}_2000_nodes", REAL_TIME_FACTOR_LIMITS[material]
        entry = None if realtime is None else realtime[name]
        factor = None if entry is None else entry["real_time_factor"]
        targets[name] = {
            "what": f"real-time factor, {what}, about 2000 nodes, one core",
            "nodes": None if entry is None else entry["nodes"],
            "timestep_s": None if entry is None else entry["run_timestep_s"],
            "value": factor, "limit": limit,
            "pass": None if factor is None else factor >= limit}
    return targets


def _profile(params: TissueBenchParams) -> dict[str, Any]:
    """Where a step of the default meat's implicit step goes, at the size nearest 1000 nodes
    (:mod:`cell.bench.tissue_profile`), on a run of its own after the warm-up."""
    size = min(params.cell_sizes_m, key=lambda cell: abs(cell - 0.028))
    run = tissue_run(bench_scenario(default_meat(), size, "implicit"))
    run.step(params.warmup_steps)
    return step_profile(run, timing_steps(params, run.scene.node_count))


def run_tissue_bench(params: TissueBenchParams | None = None,
                     progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Run every tissue model and both peers at every size; returns the JSON-ready report
    (module docstring). ``progress`` receives a line per finished part.

    ``tests/bench/test_tissue.py`` runs it with :meth:`TissueBenchParams.quick`.
    """
    params = TissueBenchParams() if params is None else params
    say = progress or (lambda line: None)
    start = time.perf_counter()
    realism: dict[str, dict[str, Any]] = {}
    for model in tissue_variants():
        # The tension test is static: both steps of one material share it.
        same = [key for key, entry in realism.items() if entry["material"] == model.material]
        realism[model.key] = (realism[same[0]] if same else {
            "material": model.material,
            **force_errors(model.material, params.cell_sizes_m, params.reference_cells,
                           params.block_side_m, params.block_strain)})
        say(f"tension test {model.key}: reference {realism[model.key]['reference_force_n']:.4g}"
            " N")
    sizes = []
    for cell_size in params.cell_sizes_m:
        sizes.append(_bench_size(cell_size, params, realism))
        say(f"size {cell_size} m ({sizes[-1]['nodes']} nodes) done")
    realtime = None
    if params.realtime_cell_size_m is not None:
        size = params.realtime_cell_size_m
        paper = paper_fig10_material(paper_damping_s(paper_fig10_material(), size))
        materials = {}
        for step in ("implicit", "explicit"):
            suffix = "" if step == "implicit" else "_explicit"
            materials |= {
                f"real_time_default_meat_2000_nodes{suffix}":
                    (f"default meat, {step} step", default_meat(), step),
                f"real_time_paper_fig10_2000_nodes{suffix}":
                    (f"paper Fig. 10 (El 0.25, Et 0.6 MPa), paper's D = 0.1 N s/m, {step} step",
                     paper, step)}
        realtime = time_runs({name: tissue_run(bench_scenario(material, size, step))
                               for name, (_, material, step) in materials.items()}, params)
        for name, (label, material, _) in materials.items():
            realtime[name] |= {"label": label, "damping_s": material.damping_s}
            say(f"{name}: {realtime[name]['real_time_factor']:.3g}x real time")
    return {
        "suite": "tissue",
        "profile": _profile(params),
        "machine": {"python": platform.python_version(), "processor": platform.machine(),
                    "mujoco": mujoco.__version__, "cpus": usable_cores(),
                    "threads_per_step": 1, "load_average": list(os.getloadavg())},
        "settings": asdict(params),
        "paper_table_1": {
            "measured_here": False,
            "note": "Nabil et al. 2015, Table 1, Core 2 Duo 3 GHz: per node per iteration; "
                    "quoted for comparison, not measured here",
            "us_per_node_iteration": PAPER_TABLE_1_US},
        "realism": {key: {k: v for k, v in entry.items() if k != "material"}
                    for key, entry in realism.items()},
        "sizes": sizes,
        "real_time": realtime,
        "targets": _targets(sizes, realtime),
        "wall_time_s": time.perf_counter() - start,
    }


def _number(value: float | None, digits: int = 3) -> str:
    return "-" if value is None else f"{value:.{digits}g}"


def _ms(seconds: float | None) -> str:
    return _number(None if seconds is None else seconds * 1e3)


def markdown_report(report: dict[str, Any]) -> str:
    """The report of :func:`run_tissue_bench` as Markdown tables (its rows are checked in
    ``tests/bench/test_tissue.py``)."""
    lines = [
        "# musclecell bench tissue",
        "",
        "Two bound muscles on the table, no robots; one thread. Stable step: largest step a "
        f"{report['settings']['stability_steps']}-step run from rest survives (capped at "
        f"{report['settings']['max_timestep_s'] * 1e3:g} ms, marked >=); formula: "
        "`MassSpringModel.stable_timestep_s(safety=1)`. The explicit step runs at 0.9 times "
        "the smaller, the implicit one at the scenario's default step. "
        "cpu: this process's CPU time (other processes do not inflate it; the wall figure is "
        "the one reported). "
        "x numpy: us/node/step over the plain numpy mass-spring peer's, same run, same mesh. "
        "Force error: tension test (cube, bottom pinned, top pulled 10%) at the same cell "
        "size, against the same model extrapolated from fine meshes.",
        "",
        "| model | nodes | us/node/step | cpu us/node/step | x numpy | stable dt (ms) "
        "| formula dt (ms) | run dt (ms) | real-time factor | force error (%) |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for size in report["sizes"]:
        rows = [*size["models"].values(), *size["peers"].values()]
        for row in rows:
            stable = row.get("stable_timestep_s")
            capped = ">=" if row.get("stable_timestep_capped") else ""
            formula = row.get("formula_timestep_s")
            lines.append(
                f"| {row['label']} | {row['nodes']} | {row['us_per_node_step']:.3g} "
                f"| {row['cpu_us_per_node_step']:.3g} | {_number(row.get('ratio_to_numpy'))} "
                f"| {capped}{_number(None if stable is None else stable * 1e3)} "
                f"| {_number(None if formula is None else formula * 1e3)} "
                f"| {row['run_timestep_s'] * 1e3:.3g} | {row['real_time_factor']:.3g} "
                f"| {_number(row.get('force_error_pct'))} |")
    lines += ["", "## Tension test references", "",
              "| model | reference force (N) | order | finest mesh error (%) |",
              "| --- | ---: | ---: | ---: |"]
    for key, entry in report["realism"].items():
        lines.append(f"| {key} | {entry['reference_force_n']:.4g} "
                     f"| {_number(entry['convergence_order'])} "
                     f"| {entry['finest_mesh_error_pct']:.2g} |")
    if report["real_time"]:
        lines += ["", "## About 2000 nodes, non-linear / linear anisotropic mass-spring, "
                  "implicit and explicit step", "",
                  "| material | nodes | damping (s) | stable dt (ms) | formula dt (ms) "
                  "| run dt (ms) | us/node/step | cpu us/node/step | real-time factor |",
                  "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
        for entry in report["real_time"].values():
            lines.append(f"| {entry['label']} | {entry['nodes']} | {entry['damping_s']:.2g} "
                         f"| {_ms(entry['stable_timestep_s'])} "
                         f"| {_ms(entry['formula_timestep_s'])} "
                         f"| {entry['run_timestep_s'] * 1e3:.3g} "
                         f"| {entry['us_per_node_step']:.3g} "
                         f"| {entry['cpu_us_per_node_step']:.3g} "
                         f"| {entry['real_time_factor']:.3g} |")
    lines += _profile_lines(report["profile"])
    lines += ["", "## Targets", "", "| target | value | limit | pass |",
              "| --- | ---: | ---: | --- |"]
    for name, target in report["targets"].items():
        verdict = "not run" if target["pass"] is None else str(target["pass"]).lower()
        lines.append(f"| {name} ({target['what']}) | {_number(target['value'])} "
                     f"| {target['limit']:g} | {verdict} |")
    paper = report["paper_table_1"]
    lines += ["", "## Paper, Table 1 (NOT measured here)", "", paper["note"] + ".", "",
              "| code | us per node per iteration |", "| --- | ---: |"]
    lines += [f"| {name} | {value:g} |" for name, value in paper["us_per_node_iteration"].items()]
    return "\n".join(lines) + "\n"


def _profile_lines(profile: dict[str, Any]) -> list[str]:
    """The step's profile and the spring kernel against its floor, as Markdown."""
    per_node = profile["us_per_node_step"]
    lines = ["", f"## Where a step goes: default meat, implicit step, {profile['nodes']} nodes",
             "", "| part | us/step | us/node/step |", "| --- | ---: | ---: |"]
    lines += [f"| {part} | {us:.3g} | {per_node[part]:.3g} |"
              for part, us in profile["us_per_step"].items()]
    lines += [f"| mujoco: {stage} | {us:.3g} | {us / profile['nodes']:.3g} |"
              for stage, us in profile["mujoco_stages_us_per_step"].items()]
    kernel = profile["kernel"]
    moved = kernel["bytes_per_spring"]
    lines += ["", "| springs | kernel ns/spring (mean, law step, tangent-line step) "
              "| floor ns/spring | bytes/spring (law, tangent line, floor) | floor GB/s |",
              "| ---: | ---: | ---: | ---: | ---: |",
              f"| {kernel['springs']} | {kernel['ns_per_spring']:.3g}, "
              f"{kernel['law_ns_per_spring']:.3g}, {kernel['linearised_ns_per_spring']:.3g} "
              f"| {kernel['floor_ns_per_spring']:.3g} | {moved['law']}, {moved['linearised']}, "
              f"{moved['floor']} | {kernel['floor_gb_per_s']:.3g} |"]
    return lines
