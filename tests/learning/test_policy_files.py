"""Policy files that cannot run code (issue 36): a saved policy reloads to the same actions and
a resume to the same training state from numbers and JSON; pickles placed in a run folder
(its statistics, its policy archive, inside an array file) are refused unrun; an earlier
release's run converts only on an explicit flag. And the paired comparison's statistics on
constructed examples."""

import base64
import json
import pickle
import zipfile
from pathlib import Path

import numpy as np
import pytest

from cell.cli import main
from cell.errors import LearningError, PickledPolicyError
from cell.learning.paired import compare, paired_mean_difference, paired_success_difference

pytest.importorskip("stable_baselines3")


class _Marker:
    """Unpickling it creates the file ``path``: what a malicious pickle could do."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __reduce__(self) -> tuple:
        return open, (str(self.path), "w")


@pytest.fixture
def marker(tmp_path: Path) -> Path:
    return tmp_path / "pwned"


def _evil(marker: Path) -> bytes:
    return pickle.dumps(_Marker(marker))


def _model_and_statistics():
    """A small PPO model on Pendulum and its VecNormalize with non-trivial statistics."""
    import gymnasium as gym
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    normalize = VecNormalize(DummyVecEnv([lambda: gym.make("Pendulum-v1")]))
    normalize.obs_rms.update(np.random.default_rng(0).normal(1.0, 2.0, size=(50, 3)))
    from stable_baselines3.common.logger import Logger

    model = PPO("MlpPolicy", normalize, n_steps=16, batch_size=16, n_epochs=1, seed=0,
                device="cpu", policy_kwargs={"net_arch": [8], "log_std_init": -1.0})
    # A logger of its own: SB3's default makes a folder in the system's temporary directory.
    model.set_logger(Logger(None, []))
    return model, normalize


def _observations() -> np.ndarray:
    return np.random.default_rng(1).normal(size=(6, 3)).astype(np.float32)


def test_the_evil_pickle_does_create_its_marker_when_unpickled(marker: Path) -> None:
    pickle.loads(_evil(marker))  # the tests below would notice an unpickling
    assert marker.exists()


def test_a_saved_policy_reloads_to_the_same_actions(tmp_path: Path) -> None:
    from cell.learning.baselines import load_learned
    from cell.learning.policyfile import save_policy

    model, normalize = _model_and_statistics()
    model.learn(16)  # weights and Adam's state away from their initial values
    save_policy(tmp_path, model, normalize, "Pendulum-v1")
    loaded = load_learned(str(tmp_path))
    assert loaded.env_id == "Pendulum-v1"
    for obs in _observations():
        wanted = model.predict(normalize.normalize_obs(obs), deterministic=True)[0]
        np.testing.assert_array_equal(loaded(obs), wanted)
    with np.load(tmp_path / "policy.npz", allow_pickle=False) as arrays:
        assert all(arrays[name].dtype != object for name in arrays.files)


def test_a_resume_restores_weights_optimizer_statistics_and_counters(tmp_path: Path) -> None:
    import gymnasium as gym
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    from cell.learning.policyfile import (
        read_normalization,
        restore_normalization,
        restore_training,
        save_policy,
    )

    model, normalize = _model_and_statistics()
    model.learn(32)
    normalize.training = False
    save_policy(tmp_path, model, normalize, "Pendulum-v1")
    restored = restore_normalization(DummyVecEnv([lambda: gym.make("Pendulum-v1")]),
                                     read_normalization(tmp_path))
    np.testing.assert_array_equal(restored.obs_rms.mean, normalize.obs_rms.mean)
    np.testing.assert_array_equal(restored.ret_rms.var, normalize.ret_rms.var)
    assert restored.obs_rms.count == normalize.obs_rms.count and not restored.training
    fresh = PPO("MlpPolicy", restored, n_steps=16, batch_size=16, n_epochs=1, seed=1,
                device="cpu", policy_kwargs={"net_arch": [8], "log_std_init": -1.0})
    restore_training(fresh, tmp_path)
    assert (fresh.num_timesteps, fresh._n_updates) == (32, model._n_updates)
    for name, tensor in model.policy.state_dict().items():
        np.testing.assert_array_equal(fresh.policy.state_dict()[name].numpy(), tensor.numpy())
    saved, loaded = (m.policy.optimizer.state_dict() for m in (model, fresh))
    assert saved["param_groups"] == loaded["param_groups"]
    for index, entries in saved["state"].items():
        for key, value in entries.items():
            np.testing.assert_array_equal(loaded["state"][index][key].numpy(), value.numpy())


def test_a_save_that_cannot_write_the_optimizer_leaves_the_last_save_whole(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from cell.learning.policyfile import save_policy

    model, normalize = _model_and_statistics()
    save_policy(tmp_path, model, normalize, "Pendulum-v1")
    before = {path.name: path.read_bytes() for path in tmp_path.iterdir()}
    model.learn(16)
    write_bytes = Path.write_bytes

    def disk_full_at_the_optimizer(path: Path, data: bytes) -> int:
        if "optimizer" in path.name:
            raise OSError(28, "No space left on device")
        return write_bytes(path, data)

    monkeypatch.setattr(Path, "write_bytes", disk_full_at_the_optimizer)
    with pytest.raises(OSError, match="No space left"):
        save_policy(tmp_path, model, normalize, "Pendulum-v1")
    assert {path.name: path.read_bytes() for path in tmp_path.iterdir()} == before


def _pickled_run(run: Path, marker: Path) -> Path:
    """An earlier release's run folder whose statistics and policy archive are malicious
    pickles (the archive as Stable-Baselines3 writes it: serialized entries in ``data``, torch
    pickles beside it)."""
    run.mkdir()
    (run / "vecnormalize.pkl").write_bytes(_evil(marker))
    serialized = base64.b64encode(_evil(marker)).decode()
    with zipfile.ZipFile(run / "policy.zip", "w") as archive:
        archive.writestr("data", json.dumps({"policy_class": {":serialized:": serialized}}))
        archive.writestr("policy.pth", _evil(marker))
        archive.writestr("pytorch_variables.pth", _evil(marker))
    (run / "learn.json").write_text(json.dumps({"env_id": "musclecell/Cut-v1", "steps": 16}))
    checkpoint = run / "checkpoints" / "steps_000000016"
    checkpoint.mkdir(parents=True)
    for name in ("vecnormalize.pkl", "policy.zip"):
        (checkpoint / name).write_bytes((run / name).read_bytes())
    (checkpoint / "state.json").write_text(json.dumps({"env_id": "musclecell/Cut-v1",
                                                        "steps": 16}))
    return run


def test_a_pickled_run_is_refused_unrun_with_how_to_convert(
        tmp_path: Path, marker: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from cell.learning.baselines import load_learned

    run = _pickled_run(tmp_path / "run", marker)
    with pytest.raises(PickledPolicyError, match=r"convert-policy .* --trust-pickle"):
        load_learned(str(run))
    for argv in (["evaluate", str(run), "Cut-v1", "--episodes", "1", "--out",
                  str(tmp_path / "eval")],
                 ["evaluate", str(run / "policy.zip"), "Cut-v1", "--out", str(tmp_path / "e")],
                 ["learn", "Cut-v1", "--steps", "32", "--envs", "1", "--out", str(run),
                  "--resume"],
                 ["convert-policy", str(run)]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert "pickle" in err, argv
    assert not marker.exists()
    assert not (tmp_path / "eval").exists()


def test_pickles_in_the_new_files_are_refused_unrun(tmp_path: Path, marker: Path) -> None:
    from cell.learning.baselines import load_learned
    from cell.learning.policyfile import save_policy

    model, normalize = _model_and_statistics()
    good = tmp_path / "good"
    save_policy(good, model, normalize, "Pendulum-v1")
    # An array file with an object array (a pickle inside the .npy entry).
    evil_arrays = tmp_path / "arrays"
    evil_arrays.mkdir()
    for name in ("policy.json", "normalization.json"):
        (evil_arrays / name).write_bytes((good / name).read_bytes())
    with np.load(good / "policy.npz") as arrays:
        contents = dict(arrays)
    contents["weights.log_std"] = np.array([_Marker(marker)], dtype=object)
    np.savez(evil_arrays / "policy.npz", **contents)
    with pytest.raises(LearningError, match=r"policy\.npz: not a policy's arrays"):
        load_learned(str(evil_arrays))
    # A pickle where the statistics go, and where the whole array file goes.
    for name, match in (("normalization.json", "normalization.json"),
                        ("policy.npz", r"policy\.npz")):
        folder = tmp_path / name.replace(".", "_")
        folder.mkdir()
        for kept in ("policy.json", "policy.npz", "normalization.json"):
            (folder / kept).write_bytes((good / kept).read_bytes())
        (folder / name).write_bytes(_evil(marker))
        with pytest.raises(LearningError, match=match):
            load_learned(str(folder))
    assert not marker.exists()


def test_an_earlier_release_s_run_converts_only_with_trust_pickle(tmp_path: Path) -> None:
    from cell.learning.baselines import load_learned

    model, normalize = _model_and_statistics()
    run = tmp_path / "old"
    run.mkdir()
    model.save(run / "policy.zip")
    (run / "vecnormalize.pkl").write_bytes(pickle.dumps(normalize))
    (run / "learn.json").write_text(json.dumps({"env_id": "Pendulum-v1"}))
    assert main(["convert-policy", str(run)]) == 2
    assert not (run / "policy.npz").exists()
    assert main(["convert-policy", str(run), "--trust-pickle"]) == 0
    loaded = load_learned(str(run))
    for obs in _observations():
        wanted = model.predict(normalize.normalize_obs(obs), deterministic=True)[0]
        np.testing.assert_array_equal(loaded(obs), wanted)


# -- the paired comparison -----------------------------------------------------------------

def test_the_paired_success_difference_matches_a_published_example() -> None:
    # Cavo et al. (2012) as in Fagerland, Lydersen and Laake, "Statistical Analysis of
    # Contingency Tables", chapter 8: 59 both, 6 first only, 16 second only, 80 neither;
    # Newcombe's square-and-add interval -0.0621 (-0.1186 to -0.0046).
    first = [True] * 65 + [False] * 96
    second = [True] * 59 + [False] * 6 + [True] * 16 + [False] * 80
    result = paired_success_difference(first, second)
    assert (result["both"], result["first_only"], result["second_only"], result["neither"]) == (
        59, 6, 16, 80)
    assert round(result["difference"], 4) == -0.0621
    assert (round(result["low"], 4), round(result["high"], 4)) == (-0.1186, -0.0046)
    # Exact McNemar: 6 of 22 discordant pairs, two-sided binomial(22, 1/2).
    from math import comb
    assert result["mcnemar_p"] == pytest.approx(2 * sum(comb(22, k) for k in range(7)) / 2**22)


def test_the_pairing_narrows_the_interval_of_correlated_outcomes() -> None:
    # The same rates, 30 of 50 against 25 of 50: concordant outcomes (the same hard worlds
    # fail for both) give a narrower interval than outcomes that share nothing.
    first = [True] * 30 + [False] * 20
    concordant = [True] * 25 + [False] * 25
    crossed = [False] * 20 + [True] * 25 + [False] * 5
    narrow = paired_success_difference(first, concordant)
    wide = paired_success_difference(first, crossed)
    assert narrow["difference"] == wide["difference"] == pytest.approx(0.1)
    assert narrow["low"] > 0 > wide["low"]
    assert narrow["high"] - narrow["low"] < wide["high"] - wide["low"]


def test_the_paired_mean_difference_is_the_t_interval_of_the_per_seed_differences() -> None:
    # Differences 0.1, 0.2, 0.3: mean 0.2, standard error 0.1 / sqrt(3), t(0.975, 2) 4.3027.
    result = paired_mean_difference([0.5, 0.6, 0.7], [0.4, 0.4, 0.4])
    half = 4.302652729911275 * 0.1 / np.sqrt(3)
    assert result["mean"] == pytest.approx(0.2)
    assert (result["low"], result["high"]) == pytest.approx((0.2 - half, 0.2 + half))


def test_compare_pairs_the_rows_by_seed_whatever_their_order() -> None:
    rows = [{"policy": "learned", "seed": s, "success": s != 2, "torn_fraction": 0.1 * s,
             "released_fraction": 1.0} for s in (3, 1, 2)]
    rows += [{"policy": "knife", "seed": s, "success": s == 1, "torn_fraction": 0.0,
              "released_fraction": 1.0} for s in (1, 2, 3, 4)]
    result = compare(rows, "learned", "knife")
    assert result["episodes"] == 3  # seed 4 was played by one of them only
    assert (result["success"]["first_only"], result["success"]["second_only"]) == (1, 0)
    assert result["torn_fraction"]["mean"] == pytest.approx(0.2)


@pytest.mark.parametrize(("change", "message"), [
    ({"format": "sb3"}, "format"),
    ({"env_id": 3}, "env_id"),
    ({"policy_kwargs": {"net_arch": [64, "x"], "activation_fn": "Tanh", "log_std_init": 0.0,
                        "share_features_extractor": True}}, "policy_kwargs.net_arch"),
    ({"policy_kwargs": {"net_arch": [8], "activation_fn": "os.system", "log_std_init": 0.0,
                        "share_features_extractor": True}}, "policy_kwargs.activation_fn"),
    ({"policy_kwargs": {"net_arch": [16], "activation_fn": "Tanh", "log_std_init": -1.0,
                        "share_features_extractor": True}}, "do not fit"),
    ({"num_timesteps": True}, "num_timesteps"),
])
def test_a_wrong_policy_json_is_named(tmp_path: Path, change: dict, message: str) -> None:
    from cell.learning.baselines import load_learned
    from cell.learning.policyfile import save_policy

    model, normalize = _model_and_statistics()
    save_policy(tmp_path, model, normalize, "Pendulum-v1")
    record = json.loads((tmp_path / "policy.json").read_text())
    (tmp_path / "policy.json").write_text(json.dumps({**record, **change}))
    with pytest.raises(LearningError, match=message):
        load_learned(str(tmp_path))
