"""`musclecell learn` and `musclecell evaluate` end to end on short, coarse episodes: the files
a run writes, a checkpoint that acts as the saved model, a resume, the evaluation table with the
demonstrator's row and the paired comparison, the baselines alone, episodes in worker
processes, and bad input as named errors with exit code 2."""

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from cell.cli import main
from cell.learning.baselines import PolicySpec, constant_grid, constant_pairs, load_learned
from cell.learning.environments import make_env
from cell.learning.evaluate import EpisodeTask, episode_runner
from cell.learning.table import MEAN_COLUMNS
from envs.observation import OBSERVATION_NAMES
from envs.policies import TableSkimmingKnife

ENV_ID = "musclecell/Cut-v1"
#: Short, coarse episodes: 10 control steps on a short muscle pair.
ENV_KWARGS = {"time_limit_s": 0.2, "cell_size_m": 0.08, "options": {"tissue": {"length_m": 0.3}}}
HYPER = {"n_steps": 16, "batch_size": 16, "n_epochs": 2}
LEARN = ["learn", ENV_ID, "--envs", "1", "--checkpoint-every", "16"]


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("learn") / "run"
    assert main([*LEARN, "--steps", "32", "--out", str(out), "--seed", "3",
                 "--env-kwargs", json.dumps(ENV_KWARGS), "--hyper", json.dumps(HYPER)]) == 0
    return out


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as file:
        return list(csv.DictReader(file))


def test_a_run_writes_its_policy_checkpoints_logs_and_curve(run: Path) -> None:
    learned = json.loads((run / "learn.json").read_text())
    assert (learned["env_id"], learned["steps"], learned["seed"]) == (ENV_ID, 32, 3)
    assert learned["hyper"]["n_steps"] == 16 and learned["stopped_by"] == "steps"
    for name in ("policy.npz", "policy.json", "normalization.json", "optimizer.npz",
                 "progress.csv", "learning_curve.png"):
        assert (run / name).stat().st_size > 0
    assert sorted(p.name for p in (run / "checkpoints").iterdir()) == [
        "steps_000000016", "steps_000000032"]
    episodes = _rows(run / "episodes.csv")
    assert len(episodes) == 3  # 10-step episodes
    assert set(episodes[0]) == {"steps", "return", "length", "success", "released_fraction",
                                "torn_fraction"}
    assert len(_rows(run / "progress.csv")) == 2  # one row per update


def test_a_checkpoint_acts_as_the_saved_model(run: Path) -> None:
    rng = np.random.default_rng(0)
    observations = rng.normal(size=(5, len(OBSERVATION_NAMES))).astype(np.float32)
    final = load_learned(str(run))
    checkpoint = load_learned(str(run / "checkpoints" / "steps_000000032"))
    earlier = load_learned(str(run / "checkpoints" / "steps_000000016"))
    for obs in observations:
        np.testing.assert_array_equal(final(obs), checkpoint(obs))
        assert final(obs).shape == (4,)
    assert any(not np.array_equal(final(obs), earlier(obs)) for obs in observations)


def test_a_resume_continues_the_steps_with_the_next_seeds(run: Path, tmp_path: Path) -> None:
    import shutil

    copy = tmp_path / "run"
    shutil.copytree(run, copy)
    before = len(_rows(copy / "episodes.csv"))
    assert main([*LEARN[:2], "--envs", "1", "--steps", "48", "--out", str(copy),
                 "--resume"]) == 0
    learned = json.loads((copy / "learn.json").read_text())
    assert learned["steps"] == 48 and learned["next_seed"] == 5  # seed 3, then 4
    steps = [int(row["steps"]) for row in _rows(copy / "episodes.csv")]
    assert len(steps) > before and steps == sorted(steps) and steps[-1] <= 48


@pytest.mark.slow  # episodes of every policy
def test_the_evaluation_table_has_every_column_for_every_policy(run: Path, tmp_path: Path
                                                                ) -> None:
    assert main(["evaluate", str(run / "policy.json"), ENV_ID, "--episodes", "2",
                 "--workers", "1", "--env-kwargs", json.dumps(ENV_KWARGS),
                 "--constant-search-seeds", "1", "--constant-actions", "[[0,0,0,0],[1,0,0,0]]",
                 "--out", str(tmp_path)]) == 0
    report = json.loads((tmp_path / "evaluation.json").read_text())
    assert list(report["policies"]) == ["random", "best-constant", "scripted",
                                        "table-skimming-knife", "learned"]
    for entry in report["policies"].values():
        assert entry["episodes"] == 2
        assert 0 <= entry["success_rate"]["low"] <= entry["success_rate"]["high"] <= 1
        for column in MEAN_COLUMNS:
            assert entry[column]["low"] <= entry[column]["mean"] <= entry[column]["high"]
    assert report["best_constant"]["chosen"]["action"] in ([0, 0, 0, 0], [1, 0, 0, 0])
    assert report["seeds"] == [100000, 100001]
    episodes = _rows(tmp_path / "episodes.csv")
    assert [(row["policy"], row["seed"]) for row in episodes][:3] == [
        ("random", "100000"), ("random", "100001"), ("best-constant", "100000")]
    markdown = (tmp_path / "evaluation.md").read_text()
    assert "| learned | 2 |" in markdown and "| table-skimming-knife | 2 |" in markdown
    # The learned policy paired with the demonstrator on the same seeds.
    comparison = report["comparison"]
    assert (comparison["policy"], comparison["against"], comparison["episodes"]) == (
        "learned", "table-skimming-knife", 2)
    pairs = {(row["policy"], row["seed"]): row for row in report["episodes"]}
    torn = [pairs["learned", s]["torn_fraction"] - pairs["table-skimming-knife", s]["torn_fraction"]
            for s in (100000, 100001)]
    assert comparison["torn_fraction"]["mean"] == pytest.approx(np.mean(torn))
    assert comparison["success"]["low"] <= comparison["success"]["difference"] <= comparison[
        "success"]["high"]
    assert "Paired on the same 2 seeds: learned less table-skimming-knife" in markdown


def test_the_baselines_alone_with_the_demonstrator_that_fits(tmp_path: Path) -> None:
    assert main(["evaluate", "Pull-v1", "--episodes", "1", "--workers", "1",
                 "--env-kwargs", json.dumps(ENV_KWARGS), "--constant-search-seeds", "1",
                 "--constant-actions", "[[0,0,0]]", "--out", str(tmp_path)]) == 0
    report = json.loads((tmp_path / "evaluation.json").read_text())
    assert list(report["policies"]) == ["random", "best-constant", "scripted",
                                        "hold-then-pull-away"]
    assert report["policy"] is None and report["comparison"] is None
    assert "Evaluation of the baselines on musclecell/Pull-v1" in (
        tmp_path / "evaluation.md").read_text()


@pytest.mark.slow
def test_the_best_constant_is_searched_on_one_axis_then_on_two(run: Path, tmp_path: Path
                                                               ) -> None:
    assert main(["evaluate", str(run), ENV_ID, "--episodes", "1", "--workers", "2",
                 "--env-kwargs", json.dumps(ENV_KWARGS), "--constant-search-seeds", "1",
                 "--out", str(tmp_path)]) == 0
    search = json.loads((tmp_path / "evaluation.json").read_text())["best_constant"]
    actions = [tuple(score["action"]) for score in search["scores"]]
    single = constant_grid(4)
    assert actions[:len(single)] == single
    best_single = max(search["scores"][:len(single)],
                      key=lambda score: (score["success_rate"], score["mean_return"]))
    assert actions[len(single):] == [a for a in constant_pairs(tuple(best_single["action"]))
                                     if a not in single]
    assert search["chosen"] == max(search["scores"], key=lambda score: (
        score["success_rate"], score["mean_return"]))


@pytest.mark.slow  # a training run
def test_a_warm_start_clones_the_demonstrator_before_ppo(run: Path, tmp_path: Path) -> None:
    out = tmp_path / "warm"
    hyper = {**HYPER, "log_std_init": -3.0, "learn_log_std": False}
    assert main([*LEARN, "--steps", "16", "--out", str(out), "--seed", "5",
                 "--env-kwargs", json.dumps(ENV_KWARGS), "--hyper", json.dumps(hyper),
                 "--warm-start", "table-skimming-knife", "--warm-start-episodes", "3",
                 "--warm-start-anchor", "1"]) == 0
    warm_start = json.loads((out / "learn.json").read_text())["warm_start"]
    assert warm_start["settings"]["anchor_epochs"] == 1
    record = warm_start["result"]
    assert record["demonstrator"] == "table-skimming-knife"
    assert record["env_steps"] == 3 * 10 * (1 + record["rounds"])  # 10-step episodes
    assert record["action_mse"] < 1e-3
    # On the first demonstrated world (the training env's first seed), after one PPO update,
    # the warm-started policy acts as the demonstrator does and a cold-started one does not.
    env = make_env(ENV_ID, ENV_KWARGS)
    obs, _ = env.reset(seed=5)
    warm, cold, demonstrator = load_learned(str(out)), load_learned(str(run)), TableSkimmingKnife()
    warm_errors, cold_errors = [], []
    for _ in range(10):
        wanted = demonstrator(obs)
        warm_errors.append(np.abs(warm(obs) - wanted).mean())
        cold_errors.append(np.abs(cold(obs) - wanted).mean())
        obs, *_ = env.step(wanted)
    assert np.mean(warm_errors) < 0.03 < 0.1 < np.mean(cold_errors)
    # The action noise stayed where it was set.
    log_std = load_learned(str(out)).network.log_std.detach().numpy()
    np.testing.assert_array_equal(log_std, np.full(4, -3.0, np.float32))
    # A resume keeps the warm start's record and its anchor.
    assert main([*LEARN[:2], "--envs", "1", "--steps", "32", "--out", str(out),
                 "--resume"]) == 0
    assert json.loads((out / "learn.json").read_text())["warm_start"] == warm_start


def test_the_anchor_fits_ppo_to_the_demonstrator_on_the_rollout_after_the_update() -> None:
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from cell.learning.hyper import WarmStart
    from cell.learning.warmstart import DemonstratorAnchor

    normalize = VecNormalize(DummyVecEnv([lambda: make_env(ENV_ID, ENV_KWARGS)]))
    model = PPO("MlpPolicy", normalize, n_steps=10, batch_size=10, seed=0, device="cpu")
    env, demonstrator = make_env(ENV_ID, ENV_KWARGS), TableSkimmingKnife()
    observations = [env.reset(seed=5)[0]]
    for _ in range(9):
        observations.append(env.step(demonstrator(observations[-1]))[0])
    raw = np.array(observations)
    normalize.obs_rms.update(raw)
    inputs = normalize.normalize_obs(raw)
    wanted = np.stack([demonstrator(obs) for obs in raw])

    def error() -> float:
        return float(np.abs(model.predict(inputs, deterministic=True)[0] - wanted).mean())

    anchor = DemonstratorAnchor(normalize, WarmStart("table-skimming-knife", anchor_epochs=100),
                                seed=0)
    anchor.init_callback(model)
    model.rollout_buffer.observations[:] = inputs[:, None, :]
    before = error()
    anchor.on_rollout_end()  # the rollout's observations, kept
    assert error() == before  # nothing moves before PPO's update
    anchor.on_rollout_start()  # the next rollout, after the update: held
    assert error() < 0.2 * before


@pytest.mark.slow  # episodes in two processes
def test_worker_processes_play_the_episodes_as_this_process_does() -> None:
    tasks = [EpisodeTask(ENV_ID, json.dumps(ENV_KWARGS), PolicySpec("random"), seed)
             for seed in (100000, 100001)]
    rows = {}
    for workers in (1, 2):
        with episode_runner(workers) as run_tasks:
            rows[workers] = [{k: v for k, v in row.items() if k != "wall_s"}
                             for row in run_tasks(tasks)]
    assert rows[1] == rows[2]
    assert [row["seed"] for row in rows[2]] == [100000, 100001]


@pytest.mark.parametrize(("argv", "message"), [
    (["learn", "Nope-v0", "--steps", "8", "--out", "unused"], "unknown env 'Nope-v0'"),
    (["learn", "Cut-v1", "--steps", "8", "--out", "unused", "--seed", "99999", "--envs", "2"],
     "training seeds 99999..100000"),
    (["learn", "Cut-v1", "--steps", "8", "--out", "unused", "--hyper", '{"n_step": 8}'],
     "hyper.n_step: unknown"),
    (["learn", "Cut-v1", "--steps", "8", "--out", "unused", "--hyper",
      '{"learn_log_std": 1}'], "hyper.learn_log_std: must be true or false"),
    (["learn", "Cut-v1", "--steps", "8", "--out", "unused", "--warm-start", "butcher"],
     "--warm-start: unknown demonstrator 'butcher'"),
    (["learn", "Cut-v1", "--steps", "8", "--out", "unused", "--warm-start",
      "table-skimming-knife", "--warm-start-episodes", "0"], "warm_start.episodes: must be >= 1"),
    (["learn", "Cut-v1", "--steps", "8", "--out", "unused", "--warm-start-anchor", "10"],
     "--warm-start-anchor: needs --warm-start"),
    (["learn", "Cut-v1", "--steps", "8", "--out", "unused", "--address", "head"],
     "--address: not a Ray address: 'head'"),
    (["evaluate", "no/such/run", "Cut-v1"], "no/such/run/policy.npz: not found"),
    (["evaluate", "Cut-v1"], "--out: needed when no POLICY is given"),
    (["evaluate", "no/such/run", "Cut-v1", "--episodes", "0"], "--episodes: must be >= 1"),
])
def test_bad_input_is_a_named_error_and_exit_code_2(
        argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    assert message in capsys.readouterr().err
