"""Three scenario keys reach the line that uses them: a key changed in a scenario file arrives in
the compiled model, the binding force kernel and the knife's planned path."""

from __future__ import annotations

import inspect
from pathlib import Path

import numpy as np
import pytest

import cell.tissue.aponeurosis as aponeurosis
from cell.sim.assembly import build_scene
from cell.sim.episode import Episode
from cell.sim.scenario import Scenario, load_scenario
from cell.sim.simulation import TissueSimulation

#: A coarse meat, so that each scene builds quickly.
_COARSE = "[tissue]\ncell_size_m = 0.05\n"


def _scenario(folder: Path, text: str) -> Scenario:
    path = folder / "scenario.toml"
    path.write_text(_COARSE + text)
    return load_scenario(path)


def test_timestep_reaches_the_model(tmp_path: Path) -> None:
    scenario = _scenario(tmp_path, "[simulation]\ntimestep_s = 0.0025\n")
    assert build_scene(scenario, robots=False).model.opt.timestep == 0.0025


def test_binding_stiffness_reaches_the_model(tmp_path: Path,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    scenario = _scenario(tmp_path, "[aponeurosis]\nstiffness_n_m = 80.0\n")
    sim = TissueSimulation(build_scene(scenario, robots=False), scenario)
    used: list[float] = []
    kernel = aponeurosis._binding_springs
    stiffness = list(inspect.signature(kernel.py_func).parameters).index("stiffness")

    def spy(*args: object) -> None:
        used.append(args[stiffness])  # N/m
        kernel(*args)

    monkeypatch.setattr(aponeurosis, "_binding_springs", spy)
    sim.step(2)
    assert used == [80.0, 80.0]


def test_cut_speed_reaches_the_model(tmp_path: Path) -> None:
    scenario = _scenario(tmp_path, "[perception]\nenabled = false\n[cut]\nspeed_m_s = 0.05\n")
    plan = Episode(scenario).plan()
    trajectory = plan.knife
    start, end = plan.cut_window_s
    cutting = (trajectory.times_s > start) & (trajectory.times_s <= end)
    index = np.flatnonzero(cutting)
    travelled = np.linalg.norm(trajectory.positions_m[index] - trajectory.positions_m[index - 1],
                               axis=1)
    speed = travelled / (trajectory.times_s[index] - trajectory.times_s[index - 1])
    assert np.median(speed) == pytest.approx(0.05, rel=1e-9)
