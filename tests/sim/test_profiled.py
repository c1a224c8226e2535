"""``musclecell run --profile``: every part of the episode reported, and the parts adding up
to the whole (consistency, not speed: speed is ``musclecell bench``)."""

from __future__ import annotations

import io
import json
from contextlib import redirect_stdout
from pathlib import Path

import pytest

from cell.cli import main
from cell.profiling import REST
from cell.sim.profiled import EPISODE_PARTS, MUJOCO_STEP, MUJOCO_TIMERS

#: Parts the control loop runs (all but the start, the camera's first look, the plan and the
#: summary).
LOOP_PARTS = EPISODE_PARTS[EPISODE_PARTS.index("IK and servos"):EPISODE_PARTS.index("summary")]


@pytest.fixture(scope="module")
def profiled(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, dict]:
    folder = tmp_path_factory.mktemp("profile")
    scenario = folder / "short.toml"
    scenario.write_text('[scenario]\nname = "short"\nend_s = 0.4\n'
                        "[tissue]\ncell_size_m = 0.05\nlength_m = 0.3\n")
    summary = folder / "summary.json"
    printed = io.StringIO()
    with redirect_stdout(printed):
        assert main(["run", str(scenario), "--profile", "-q", "-o", str(summary)]) == 0
    return printed.getvalue(), json.loads(Path(summary).read_text())


def test_the_profile_table_names_every_part_and_mujocos_stages(profiled: tuple[str, dict]
                                                               ) -> None:
    table, _ = profiled
    rows = [line.strip() for line in table.splitlines()[2:]]  # after the run's line
    for name in (*EPISODE_PARTS, *MUJOCO_TIMERS, REST, "total"):
        assert any(row.startswith(name) for row in rows), name


def test_the_parts_add_up_to_the_whole_and_the_loop_to_the_episode(
        profiled: tuple[str, dict]) -> None:
    _, summary = profiled
    profile = summary["profile"]
    parts = profile["parts_s"]
    assert set(parts) == {*EPISODE_PARTS, REST}  # no part under a name the table lacks
    assert sum(parts.values()) == pytest.approx(profile["total_s"], rel=1e-9)
    assert min(parts.values()) >= 0.0
    assert parts[REST] < 0.2 * profile["total_s"]  # the parts cover the run
    episode_s = summary["timing"]["wall_time_s"]
    assert sum(parts[name] for name in LOOP_PARTS) <= episode_s
    assert profile["total_s"] > episode_s
    # The physics parts run once a physics step, MuJoCo's stages inside its step.
    steps = profile["calls"][MUJOCO_STEP]
    assert steps == round(summary["result"]["sim_time_s"] / 0.005)
    assert profile["calls"]["tissue law"] == profile["calls"]["implicit solve"] == steps
    stages = profile["details_s"][MUJOCO_STEP]
    assert set(stages) == {*MUJOCO_TIMERS, "other"}
    assert 0.0 < sum(stages.values()) <= parts[MUJOCO_STEP]


def test_the_summary_has_a_profile_only_when_asked(tmp_path: Path) -> None:
    scenario = tmp_path / "tiny.toml"
    scenario.write_text('[scenario]\nname = "tiny"\nend_s = 0.04\n[perception]\n'
                        "enabled = false\n[tissue]\ncell_size_m = 0.05\nlength_m = 0.3\n")
    assert main(["run", str(scenario), "-q", "-o", str(tmp_path / "s.json")]) == 0
    assert set(json.loads((tmp_path / "s.json").read_text())) == {"result", "arms", "timing"}
