"""Domain randomisation: the default distribution, its draws, its errors, the env's use of it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from cell.errors import InputError, RandomizationError
from cell.sim.assembly import build_scene
from cell.sim.scenario import Scenario
from cell.sim.simulation import Simulation
from cell.tissue.shape import MuscleShape
from envs import CutEnv, PullEnv, apply_options
from envs.randomization import Distribution, Randomization, draw, load_randomization
from envs.settings import PULL_KNIFE_CLEARANCE_M

DEFAULT = load_randomization()


def _values(world: dict, key: str) -> list[float]:
    name = key.removeprefix("tissue.")
    value = world["tissue"][name] if name != key else world[key]
    return value if isinstance(value, list) else [value]


def test_every_draw_lies_in_its_range() -> None:
    rng = np.random.default_rng(7)
    worlds = [draw(DEFAULT, rng) for _ in range(100)]
    for key, distribution in DEFAULT.entries:
        low, high = distribution.bounds
        values = [v for world in worlds for v in _values(world, key)]
        assert len(values) == 100 * distribution.size
        assert all(low <= v <= high for v in values), key
        assert len(set(values)) > 1, key  # it does vary


def test_same_seed_same_world_other_seed_other_world() -> None:
    def world(seed: int) -> dict:
        return draw(DEFAULT, np.random.default_rng(seed))

    assert world(3) == world(3)
    assert world(3) != world(4)


def test_normal_draws_are_clipped_and_choices_chosen() -> None:
    rng = np.random.default_rng(0)
    wide = Distribution("normal", low=-0.1, high=0.2, mean=0.0, std=10.0, size=50)
    values = wide.sample(rng)
    assert min(values) == -0.1 and max(values) == 0.2
    assert set(Distribution("choice", values=(0.3, 0.5), size=40).sample(rng)) == {0.3, 0.5}


def _file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "randomization.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(("text", "key", "message"), [
    ('[stiffnes_n_m]\nkind = "uniform"\nlow = 1.0\nhigh = 2.0\n', "stiffnes_n_m", "unknown key"),
    ('[tissue.length]\nkind = "uniform"\nlow = 0.4\nhigh = 0.5\n', "tissue.length",
     "unknown shape field"),
    ('[force_scale]\nkind = "uniform"\nlow = "low"\nhigh = 2.0\n', "force_scale.low",
     "expected"),
    ('[force_scale]\nkind = "gauss"\nlow = 1.0\nhigh = 2.0\n', "force_scale.kind",
     "must be one of"),
    ('[force_scale]\nkind = "uniform"\nlow = 1.2\nhigh = 0.8\n', "force_scale.low",
     "must be <= high"),
    ('[force_scale]\nkind = "uniform"\nlow = -0.5\nhigh = 1.0\n', "force_scale",
     "must be > 0"),
    ('[tissue.valley_depth_m]\nkind = "uniform"\nlow = 0.01\nhigh = 0.2\n',
     "tissue.valley_depth_m", "must be in"),
    ('[force_bias_n]\nkind = "uniform"\nlow = 0.0\nhigh = 0.1\n', "force_bias_n",
     "expected a list"),
    ('[table_friction]\nkind = "normal"\nlow = 0.4\nhigh = 0.8\n', "table_friction.mean",
     "needed"),
    ("force_scale = 1.0\n", "force_scale", "expected a table"),
])
def test_a_bad_file_names_the_file_and_the_key(tmp_path: Path, text: str, key: str,
                                                message: str) -> None:
    path = _file(tmp_path, text)
    with pytest.raises(RandomizationError, match=message) as caught:
        load_randomization(path)
    assert caught.value.file == str(path) and caught.value.field == key
    assert isinstance(caught.value, InputError)


def test_a_missing_file_is_named(tmp_path: Path) -> None:
    with pytest.raises(RandomizationError, match="file not found"):
        load_randomization(tmp_path / "nowhere.toml")


def test_the_env_applies_the_drawn_world() -> None:
    env = PullEnv(time_limit_s=0.5)
    _, info = env.reset(seed=0)
    scenario = env.episode.scenario
    assert scenario.tissue.length_m == info["world"]["tissue"]["length_m"] != 0.45
    assert scenario.aponeurosis.stiffness_n_m == info["world"]["aponeurosis_stiffness_n_m"]
    assert scenario.sensors.force_bias_n == tuple(info["world"]["force_bias_n"])
    table = env.episode.sim.model.geom("table")
    assert table.friction[0] == pytest.approx(info["world"]["table_friction"])
    first = env.episode.scene.mesh.shank.points.copy()
    env.reset(seed=1)
    assert env.episode.scene.mesh.shank.points.shape != first.shape or not np.allclose(
        env.episode.scene.mesh.shank.points, first)
    # Explicit options override the draw key by key; the nominal world is one option away.
    _, info = env.reset(seed=0, options={"tissue": {"length_m": 0.42}, "force_scale": 1.0})
    assert env.episode.scenario.tissue.length_m == 0.42
    assert info["world"]["force_scale"] == 1.0 and "round_width_m" in info["world"]["tissue"]
    _, info = env.reset(seed=0, options={"randomize": False})
    # Pull-v1's own option stays: its knife's plan cuts down to the table.
    assert info["world"] == {"cut_table_clearance_m": PULL_KNIFE_CLEARANCE_M}
    assert env.episode.scenario.tissue.length_m == 0.45


def test_a_sensor_bias_survives_the_tare() -> None:
    scenario = apply_options(Scenario(tissue=MuscleShape(cell_size_m=0.05)),
                             {"force_bias_n": [0.2, 0.0, -0.1], "force_noise_n": 0.0})
    sim = Simulation(build_scene(scenario), scenario)
    sim.tare()
    np.testing.assert_allclose(sim.read("knife/force"), [0.2, 0.0, -0.1])


def test_randomize_must_be_a_bool() -> None:
    with pytest.raises(InputError, match="randomize"):
        CutEnv().reset(seed=0, options={"randomize": "no"})


def test_check_env_passes_with_randomisation() -> None:
    env = CutEnv(time_limit_s=0.5)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.parametrize(("key", "good", "bad", "reason"), [
    ("aponeurosis_stiffness_n_m", 50.0, 1e9, "diverged"),  # blows up on the approach
    ("longitudinal_scale", 1.0, 1e3, "springs can give"),  # refused as the cell is built
])
def test_a_world_that_fails_is_drawn_again(key: str, good: float, bad: float,
                                           reason: str) -> None:
    randomization = Randomization(((key, Distribution("choice", values=(good, bad))),))
    env = CutEnv(time_limit_s=0.5, randomization=randomization)
    _, info = env.reset(seed=0)  # seed 0 draws the bad value first
    assert info["redraws"] and all(reason in why for why in info["redraws"])
    assert info["world"][key] != bad and not info["diverged"]


def test_a_divergence_ends_the_step_not_the_program() -> None:
    env = CutEnv(time_limit_s=0.5, randomize=False,
                 options={"aponeurosis_stiffness_n_m": 1e9})
    env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert info["diverged"] and terminated and not truncated
    assert np.isfinite(obs).all() and np.isfinite(reward)
