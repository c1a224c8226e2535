"""``musclecell bench tissue --quick``: the report's structure, every figure finite and positive."""

import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cell.bench.stability import largest_stable_timestep_s
from cell.bench.tissue_accuracy import extrapolated_force_n
from cell.bench.tissue_profile import floor_kernel
from cell.bench.tissue_variants import tissue_variants
from cell.cli import main
from cell.sim.scenario import SimulationParams

_MODELS = {model.key for model in tissue_variants()}


def _numbers(node: Any, path: str = "") -> Iterator[tuple[str, float]]:
    """Every number in a JSON tree with its dotted path (booleans are not numbers)."""
    if isinstance(node, dict):
        for key, value in node.items():
            yield from _numbers(value, f"{path}.{key}")
    elif isinstance(node, list):
        for i, value in enumerate(node):
            yield from _numbers(value, f"{path}[{i}]")
    elif isinstance(node, int | float) and not isinstance(node, bool):
        yield path, float(node)


@pytest.fixture(scope="module")
def quick_report(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, Any], str]:
    out = tmp_path_factory.mktemp("bench")
    json_path, markdown_path = out / "tissue.json", out / "tissue.md"
    code = main(["bench", "tissue", "--quick", "--out", str(json_path),
                 "--markdown", str(markdown_path)])
    assert code == 0
    return json.loads(json_path.read_text()), Path(markdown_path).read_text()


def test_quick_report_has_every_model_and_both_peers(
        quick_report: tuple[dict[str, Any], str]) -> None:
    report, _ = quick_report
    assert report["suite"] == "tissue"
    assert [size["cell_size_m"] for size in report["sizes"]] == [0.05]
    size = report["sizes"][0]
    assert 200 <= size["nodes"] <= 300
    assert set(size["models"]) == _MODELS
    assert set(size["peers"]) == {"numpy_mass_spring", "mujoco_stock_flex"}
    for entry in size["models"].values():
        for key in ("us_per_node_step", "stable_timestep_s", "run_timestep_s",
                    "real_time_factor", "force_error_pct", "ratio_to_numpy"):
            assert key in entry
        assert entry["run_timestep_s"] <= entry["stable_timestep_s"]
        if entry["family"] == "mass_spring" and entry["tissue_step"] == "explicit":
            assert entry["formula_timestep_s"] > 0
        if entry["tissue_step"] == "implicit":  # no bound: it runs at the scenario's step
            assert entry["formula_timestep_s"] is None
            assert entry["run_timestep_s"] == SimulationParams().timestep_s
    assert set(report["realism"]) == _MODELS
    assert report["paper_table_1"]["measured_here"] is False
    # --quick does not reach the targets' sizes: they are reported as not run.
    assert set(report["targets"]) == {"us_per_node_step_1000_nodes_explicit",
                                      "us_per_node_step_1000_nodes_implicit",
                                      "real_time_default_meat_2000_nodes",
                                      "real_time_paper_fig10_2000_nodes"}
    assert all(target["pass"] is None for target in report["targets"].values())


def test_every_number_is_finite_and_positive(quick_report: tuple[dict[str, Any], str]) -> None:
    report, _ = quick_report
    numbers = dict(_numbers(report))
    assert len(numbers) > 50
    bad = {path: value for path, value in numbers.items()
           if not (math.isfinite(value) and value > 0)}
    assert not bad


def test_markdown_has_a_row_per_model_and_peer(quick_report: tuple[dict[str, Any], str]) -> None:
    report, markdown = quick_report
    size = report["sizes"][0]
    for row in (*size["models"].values(), *size["peers"].values()):
        assert f"| {row['label']} | {row['nodes']} |" in markdown
    assert "NOT measured here" in markdown


def test_stable_step_search_finds_the_threshold() -> None:
    step, capped = largest_stable_timestep_s(lambda h: h < 3e-3, 1e-3, 1e-2, 0.01)
    assert not capped and 3e-3 / 1.01 <= step < 3e-3
    assert largest_stable_timestep_s(lambda h: h < 3e-3, 1e-2, 1e-2, 0.01)[0] < 3e-3
    assert largest_stable_timestep_s(lambda h: True, 1e-3, 1e-2, 0.01) == (1e-2, True)


def test_extrapolation_recovers_a_power_law_limit() -> None:
    forces = {n: 40.0 + 12.0 / n**1.5 for n in (8, 12, 16)}
    limit, order = extrapolated_force_n(forces)
    assert limit == pytest.approx(40.0, rel=1e-9)
    assert order == pytest.approx(1.5, rel=1e-6)
    assert extrapolated_force_n({4: 1.0, 8: 2.0, 16: 1.5}) == (1.5, None)


def test_the_profile_splits_a_step_and_sets_the_kernel_against_its_floor(
        quick_report: tuple[dict[str, Any], str]) -> None:
    report, markdown = quick_report
    profile = report["profile"]
    assert profile["nodes"] == report["sizes"][0]["nodes"]
    assert set(profile["us_per_step"]) == {"springs", "bindings", "implicit_solve", "mujoco"}
    kernel = profile["kernel"]
    assert kernel["bytes_per_spring"]["law"] > kernel["bytes_per_spring"]["floor"]
    # Which kernel is faster is the bench's figure, not the test's: timings on a shared
    # machine swap places (a timed test would fail at random).
    for name in ("law_ns_per_spring", "floor_ns_per_spring", "linearised_ns_per_spring"):
        assert math.isfinite(kernel[name]) and kernel[name] > 0.0
    assert f"## Where a step goes: default meat, implicit step, {profile['nodes']} nodes" \
        in markdown


def test_the_floor_kernel_is_hookes_law_with_the_kernels_data_movement() -> None:
    forces, tangent = np.zeros(6), np.zeros((1, 6))
    floor_kernel(np.array([[0.0, 0.0, 0.0], [1.1, 0.0, 0.0]]), np.zeros((2, 3)), forces,
                    np.array([0, 3]), np.array([[0, 1]]), np.array([1.0]), np.array([100.0]),
                    tangent)
    assert forces == pytest.approx([10.0, 0.0, 0.0, -10.0, 0.0, 0.0])  # 0.1 m at 100 N/m
    assert tangent[0, :3] == pytest.approx([1.0, 0.0, 0.0])
