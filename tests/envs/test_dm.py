"""The ``dm_env`` environments: dm_env's own conformance tests, and the same trajectory as
the Gymnasium env for the same seed and actions."""

from __future__ import annotations

import dm_env
import numpy as np
import pytest
from absl.testing import absltest
from dm_env import test_utils

from cell.errors import InputError
from cell.sim.assembly import build_scene, export_mjcf
from cell.sim.scenario import Scenario
from cell.tissue.geometry import MuscleShape
from envs.dm import make
from envs.tasks import CutEnv

# Episodes of five steps, so that dm_env's longer action sequence crosses an episode's end.
QUICK = {"cell_size_m": 0.05, "time_limit_s": 0.1}


class CutEnvironmentConforms(test_utils.EnvironmentTestMixin, absltest.TestCase):
    """dm_env's contract: specs, FIRST / MID / LAST, a reset after the last step."""

    def make_object_under_test(self) -> dm_env.Environment:
        return make("Cut-v2", seed=11, **QUICK)

    def make_action_sequence(self):
        # The fifth step ends an episode, the sixth starts the next.
        for _ in range(7):
            yield self.make_action()


def test_the_dm_env_steps_as_the_gymnasium_env_for_the_same_seed_and_actions() -> None:
    # The time limit is a truncation, whose discount is 1.
    kwargs = {"cell_size_m": 0.05, "time_limit_s": 0.2}
    gym_env = CutEnv(**kwargs)
    dm = make("Cut-v2", seed=12, **kwargs)
    actions = np.random.default_rng(13).uniform(-1.0, 1.0, (10, 4)).astype(np.float32)
    observation, _ = gym_env.reset(seed=12)
    first = dm.reset()
    assert first.first()
    np.testing.assert_array_equal(first.observation, observation)
    taken = 0
    for action in actions:
        taken += 1
        observation, reward, terminated, truncated, info = gym_env.step(action)
        step = dm.step(action)
        np.testing.assert_array_equal(step.observation, observation)
        assert step.reward == reward
        assert step.last() == (terminated or truncated)
        assert dm.info["released_fraction"] == info["released_fraction"]
        if step.last():
            assert step.discount == (0.0 if terminated else 1.0)
            break
    assert taken == 10 and truncated  # 0.2 s of 20 ms control steps
    # The next step starts the next episode, drawn from the env's generator as an unseeded
    # Gymnasium reset draws it.
    observation, _ = gym_env.reset()
    step = dm.step(actions[0])
    assert step.first()
    np.testing.assert_array_equal(step.observation, observation)


def test_specs_match_the_gymnasium_spaces() -> None:
    env = make("MuscleSeparation-v2", cell_size_m=0.05)
    box = env.gym_env.observation_space
    assert env.action_spec().shape == (7,)
    assert env.observation_spec().shape == box.shape
    np.testing.assert_array_equal(env.observation_spec().maximum, box.high)


def test_steer_is_a_task_with_its_own_observation() -> None:
    env = make("Steer-v2", seed=0, **QUICK)
    assert env.observation_spec().shape == (41,)
    assert env.reset().observation.shape == (41,)
    step = env.step(np.zeros(4, np.float32))
    assert step.mid() and step.observation.shape == (41,)


def test_an_unknown_task_is_named() -> None:
    with pytest.raises(InputError, match="unknown task 'Slice-v0'"):
        make("Slice-v0")


def test_dm_controls_physics_steps_the_exported_cell(tmp_path) -> None:
    # dm-control 1.0.52 runs on MuJoCo 4 (1.0.50's Physics read a field MuJoCo 4 removed):
    # the cell as `musclecell export-mjcf` writes it loads and steps there.
    from dm_control.mujoco import Physics

    scene = build_scene(Scenario(tissue=MuscleShape(cell_size_m=0.05)))
    physics = Physics.from_xml_path(str(export_mjcf(scene, tmp_path / "cell.xml")))
    assert (physics.model.nbody, physics.model.nflex) == (scene.model.nbody, scene.model.nflex)
    for _ in range(20):
        physics.step()
    assert physics.data.time == pytest.approx(20 * scene.model.opt.timestep)
    assert np.isfinite(physics.data.qpos).all()
