"""`diagnose-logs --address` on a two-node Ray cluster started here (the sweeps' fixture), as
a user with a cluster would: a tiny batch gets the same diagnosis as on this machine."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from cell.cli import main
from cell.synthetic.logs import write_hidden_log_batch
from tests.paths import PROJECT_ROOT

pytest.importorskip("ray")


QUICK = PROJECT_ROOT / "scenarios" / "quick.toml"


@pytest.mark.slow
def test_a_tiny_batch_is_diagnosed_on_a_cluster_as_on_this_machine(
        cluster: str, tmp_path: Path) -> None:
    folder = tmp_path / "batch"
    write_hidden_log_batch(folder, 5, QUICK, ("tissue_stiffness",), logs=2, end_s=1.0)
    logs = [str(folder / "log-1"), str(folder / "log-2")]
    common = ["--no-plots", "--causes", "tissue_stiffness"]
    assert main(["diagnose-logs", *logs, "--out", str(tmp_path / "ray"), "--address",
                 cluster, *common]) == 0
    assert main(["diagnose-logs", *logs, "--out", str(tmp_path / "here"), "--workers", "1",
                 *common]) == 0
    on_ray, here = (json.loads((tmp_path / name / "diagnosis.json").read_text())
                    for name in ("ray", "here"))
    timing = on_ray.pop("timing")
    assert timing["replays"] == here.pop("timing")["replays"] >= 6
    assert timing["replay_cpu_s"] > 0.0  # the cluster's workers' CPU, sent back
    assert on_ray == here
