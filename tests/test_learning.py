"""`musclecell learn` and `musclecell evaluate` end to end on short, coarse episodes: the files
a run writes, a checkpoint that acts as the saved model, a resume, the evaluation table, episodes
in worker processes, and bad input as named errors with exit code 2."""

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from cell.cli import main
from cell.learning.baselines import PolicySpec, constant_grid, constant_pairs, load_learned
from cell.learning.evaluate import EpisodeTask, episode_runner
from cell.learning.table import MEAN_COLUMNS
from envs.observation import OBSERVATION_NAMES

ENV_ID = "musclecell/Cut-v0"
#: Short, coarse episodes: 10 control steps on a short muscle pair.
ENV_KWARGS = {"time_limit_s": 0.2, "cell_size_m": 0.08, "options": {"shape": {"length_m": 0.3}}}
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
    for name in ("policy.zip", "vecnormalize.pkl", "progress.csv", "learning_curve.png"):
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


def test_the_evaluation_table_has_every_column_for_every_policy(run: Path, tmp_path: Path
                                                                ) -> None:
    assert main(["evaluate", str(run / "policy.zip"), ENV_ID, "--episodes", "2",
                 "--workers", "1", "--env-kwargs", json.dumps(ENV_KWARGS),
                 "--constant-search-seeds", "1", "--constant-actions", "[[0,0,0,0],[1,0,0,0]]",
                 "--out", str(tmp_path)]) == 0
    report = json.loads((tmp_path / "evaluation.json").read_text())
    assert list(report["policies"]) == ["random", "best-constant", "scripted", "learned"]
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
    assert "| learned | 2 |" in (tmp_path / "evaluation.md").read_text()


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
    (["learn", "Cut-v0", "--steps", "8", "--out", "unused", "--seed", "99999", "--envs", "2"],
     "training seeds 99999..100000"),
    (["learn", "Cut-v0", "--steps", "8", "--out", "unused", "--hyper", '{"n_step": 8}'],
     "hyper.n_step: unknown"),
    (["evaluate", "no/such/run", "Cut-v0"], "no/such/run/policy.zip: not found"),
    (["evaluate", "no/such/run", "Cut-v0", "--episodes", "0"], "--episodes: must be >= 1"),
])
def test_bad_input_is_a_named_error_and_exit_code_2(
        argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    assert message in capsys.readouterr().err
