"""A learned policy's files in formats that hold only numbers and JSON, so that loading a
policy someone sent you cannot run their code.

A run folder (and each of its checkpoints) holds:

- ``policy.npz``: the policy network's weights (its ``state_dict``, keys ``weights.NAME``)
  and the bounds of its observation and action spaces, read with ``allow_pickle=False``;
- ``policy.json``: the format, the env id, the network's architecture and PPO's counters;
- ``normalization.json``: the ``VecNormalize`` statistics (observation and return means,
  variances and counts, clips, epsilon, gamma, whether they still update);
- ``optimizer.npz``: PPO's Adam state (moments and step counts as arrays, its parameter
  groups as a JSON string), which a ``--resume`` restores.

Nothing here unpickles: Stable-Baselines3's ``policy.zip`` and the pickled
``vecnormalize.pkl`` of earlier releases are refused with :class:`~cell.errors.PickledPolicyError`
(:mod:`cell.learning.convert` converts them, on an explicit flag). torch and
Stable-Baselines3 are imported by the functions that need them.
"""

from __future__ import annotations

import io
import json
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cell.errors import LearningError, PickledPolicyError
from cell.io import read_json
from cell.outputs import json_text, write_together

if TYPE_CHECKING:
    from stable_baselines3 import PPO
    from stable_baselines3.common.policies import ActorCriticPolicy
    from stable_baselines3.common.vec_env import VecEnv, VecNormalize

WEIGHTS_FILE = "policy.npz"
POLICY_FILE = "policy.json"
NORMALIZATION_FILE = "normalization.json"
OPTIMIZER_FILE = "optimizer.npz"
#: The pickled files of earlier releases, refused on load.
PICKLED_FILES = ("policy.zip", "vecnormalize.pkl")
FORMAT = "musclecell-policy"
FORMAT_VERSION = 1
#: The activations a policy file may name, by name (nothing else is looked up).
ACTIVATIONS = ("Tanh", "ReLU")
_SPACES = ("observation_space", "action_space")


def check_policy_folder(folder: Path) -> None:
    """Raise unless ``folder`` holds a policy in this format.

    Raises:
        PickledPolicyError: it holds only the pickled files of an earlier release.
        LearningError: it holds no policy.
    """
    if (folder / WEIGHTS_FILE).is_file():
        return
    if any((folder / name).is_file() for name in PICKLED_FILES):
        raise PickledPolicyError(folder)
    raise LearningError(folder / WEIGHTS_FILE, None, "not found (POLICY must be a learn output "
                        "folder or a checkpoint folder, or a file in one)")


def read_arrays(path: Path) -> dict[str, np.ndarray]:
    """The arrays of the ``.npz`` file ``path``, read without unpickling anything.

    Raises:
        LearningError: naming ``path`` when it is not such a file, or holds an object array
            (which only a pickle could rebuild).
    """
    try:
        with np.load(path, allow_pickle=False) as archive:
            if not isinstance(archive, np.lib.npyio.NpzFile):
                raise ValueError("a single array, not an archive of named arrays")
            return {name: archive[name] for name in archive.files}
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, AttributeError
            ) as exc:
        first_line = (str(exc).strip().splitlines() or [""])[0]
        raise LearningError(path, None, f"not a policy's arrays (.npz of numbers, read "
                            f"without pickle): {type(exc).__name__}: {first_line}") from None


def _npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


def _field(record: Any, key: str, path: Path, kind: type | tuple[type, ...]) -> Any:
    """``record[key]`` if it is of ``kind`` (a bool is no number here), else a named error."""
    kinds = kind if isinstance(kind, tuple) else (kind,)
    value = record.get(key) if isinstance(record, dict) else None
    if not isinstance(value, kinds) or (isinstance(value, bool) and bool not in kinds):
        raise LearningError(path, key, f"missing or of the wrong type ({value!r})")
    return value


@dataclass(frozen=True)
class ObservationNormalizer:
    """``VecNormalize``'s observation normalisation, frozen, in NumPy: ``clip((obs - mean) /
    sqrt(var + epsilon), -clip, clip)`` (the observation unchanged when ``enabled`` is
    False).

    Example:
        >>> normalize = ObservationNormalizer(np.zeros(2), np.full(2, 4.0), 10.0, 0.0)
        >>> normalize(np.array([2.0, 100.0]))
        array([ 1., 10.])
    """

    mean: np.ndarray
    var: np.ndarray
    clip: float
    epsilon: float
    enabled: bool = True

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        if not self.enabled:
            return obs
        return np.clip((obs - self.mean) / np.sqrt(self.var + self.epsilon), -self.clip,
                       self.clip)


def normalization_record(normalize: VecNormalize) -> dict[str, Any]:
    """``normalize``'s statistics and settings as JSON-ready data."""
    def moments(stats: Any) -> dict[str, Any]:
        return {"mean": np.asarray(stats.mean, float).tolist(),
                "var": np.asarray(stats.var, float).tolist(), "count": float(stats.count)}

    return {"obs_rms": moments(normalize.obs_rms), "ret_rms": moments(normalize.ret_rms),
            "clip_obs": float(normalize.clip_obs), "clip_reward": float(normalize.clip_reward),
            "epsilon": float(normalize.epsilon), "gamma": float(normalize.gamma),
            "norm_obs": bool(normalize.norm_obs), "norm_reward": bool(normalize.norm_reward),
            "training": bool(normalize.training)}


def read_normalization(folder: Path) -> dict[str, Any]:
    """The checked record of ``folder``'s ``normalization.json``.

    Raises:
        LearningError: naming the file and the key at fault.
    """
    path = folder / NORMALIZATION_FILE
    record = read_json(path, LearningError)
    for name in ("obs_rms", "ret_rms"):
        stats = _field(record, name, path, dict)
        for key in ("mean", "var"):
            values = _field(stats, key, path, (list, float, int))
            if not np.all(np.isfinite(np.asarray(values, dtype=float))):
                raise LearningError(path, f"{name}.{key}", "must be finite numbers")
        _field(stats, "count", path, (float, int))
    for key in ("clip_obs", "clip_reward", "epsilon", "gamma"):
        _field(record, key, path, (float, int))
    for key in ("norm_obs", "norm_reward", "training"):
        _field(record, key, path, bool)
    return record


def observation_normalizer(record: dict[str, Any]) -> ObservationNormalizer:
    """The frozen observation normalisation of a :func:`read_normalization` record."""
    stats = record["obs_rms"]
    return ObservationNormalizer(np.asarray(stats["mean"], float),
                                 np.asarray(stats["var"], float), float(record["clip_obs"]),
                                 float(record["epsilon"]), record["norm_obs"])


def restore_normalization(venv: VecEnv, record: dict[str, Any]) -> VecNormalize:
    """A ``VecNormalize`` around ``venv`` with a :func:`read_normalization` record's
    statistics and settings."""
    from stable_baselines3.common.vec_env import VecNormalize

    normalize = VecNormalize(venv, training=record["training"], norm_obs=record["norm_obs"],
                             norm_reward=record["norm_reward"], clip_obs=record["clip_obs"],
                             clip_reward=record["clip_reward"], gamma=record["gamma"],
                             epsilon=record["epsilon"])
    for name in ("obs_rms", "ret_rms"):
        stats, target = record[name], getattr(normalize, name)
        target.mean = np.asarray(stats["mean"], np.float64).reshape(target.mean.shape)
        target.var = np.asarray(stats["var"], np.float64).reshape(target.var.shape)
        target.count = float(stats["count"])
    return normalize


def save_policy(folder: Path, model: PPO, normalize: VecNormalize, env_id: str) -> None:
    """Write ``model``'s policy, ``normalize``'s statistics and the optimizer's state in
    ``folder`` (the four files of this module)."""
    import torch

    policy = model.policy
    optimizer = policy.optimizer.state_dict()
    state = {f"state.{index}.{key}": torch.as_tensor(value).cpu().numpy()
             for index, entries in optimizer["state"].items() for key, value in entries.items()}
    groups = json.dumps(optimizer["param_groups"], default=list)
    save_network(folder, policy, normalization_record(normalize), env_id, "PPO",
                 int(model.num_timesteps), int(model._n_updates),
                 also={OPTIMIZER_FILE: _npz_bytes({**state, "param_groups": np.array(groups)})})


def save_network(folder: Path, policy: ActorCriticPolicy, normalization: dict[str, Any],
                 env_id: str, algorithm: str, num_timesteps: int, n_updates: int,
                 base_policy: dict[str, Any] | None = None,
                 also: dict[str, bytes] | None = None) -> None:
    """Write ``policy``'s network, trained by ``algorithm``, and the observation statistics
    ``normalization`` (a :func:`normalization_record`) in ``folder``: what :func:`read_policy` and
    :func:`read_normalization` load (a policy trained without PPO, such as
    :mod:`cell.learning.dagger`'s, has no optimizer state to resume). ``base_policy``
    (``{"name": DEMONSTRATOR, "learned": [indices]}``): the policy acts as that
    demonstrator but for the action's ``learned`` entries, which the network gives. ``also``:
    more files of the folder by name (PPO's optimizer state), written in the same change."""
    import stable_baselines3
    import torch

    if policy.use_sde or policy.squash_output:
        raise LearningError(folder, None, "only a Gaussian policy without gSDE or squashing "
                            "is saved in this format")
    arrays = {f"weights.{name}": tensor.detach().cpu().numpy()
              for name, tensor in policy.state_dict().items()}
    for space in _SPACES:
        box = getattr(policy, space)
        arrays[f"{space}.low"], arrays[f"{space}.high"] = box.low, box.high
    net_arch = policy.net_arch
    record = {
        "format": FORMAT, "version": FORMAT_VERSION, "env_id": env_id, "algorithm": algorithm,
        "policy_kwargs": {
            "net_arch": dict(net_arch) if isinstance(net_arch, dict) else list(net_arch),
            "activation_fn": policy.activation_fn.__name__,
            "log_std_init": float(policy.log_std_init),
            "share_features_extractor": bool(policy.share_features_extractor)},
        "dtypes": {space: str(getattr(policy, space).dtype) for space in _SPACES},
        "num_timesteps": num_timesteps, "n_updates": n_updates,
        **({} if base_policy is None else {"base_policy": base_policy}),
        "versions": {"stable_baselines3": stable_baselines3.__version__,
                     "torch": torch.__version__}}
    # One change: a run stopped while it saves keeps weights, statistics and optimizer that
    # match.
    write_together({folder / WEIGHTS_FILE: _npz_bytes(arrays),
                    folder / POLICY_FILE: json_text(record, folder / POLICY_FILE),
                    folder / NORMALIZATION_FILE: json_text(normalization,
                                                           folder / NORMALIZATION_FILE),
                    **{folder / name: content for name, content in (also or {}).items()}})


def read_policy(folder: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The checked ``policy.json`` record and the ``policy.npz`` arrays of ``folder``.

    Raises:
        PickledPolicyError: ``folder`` holds only an earlier release's pickled files.
        LearningError: a missing or broken file, naming it and the key at fault.
    """
    check_policy_folder(folder)
    path = folder / POLICY_FILE
    record = read_json(path, LearningError)
    if _field(record, "format", path, str) != FORMAT or _field(
            record, "version", path, int) != FORMAT_VERSION:
        raise LearningError(path, "format", f"not a {FORMAT} file of version {FORMAT_VERSION}")
    _field(record, "env_id", path, str)
    kwargs = _field(record, "policy_kwargs", path, dict)
    if _field(kwargs, "activation_fn", path, str) not in ACTIVATIONS:
        raise LearningError(path, "policy_kwargs.activation_fn", f"one of {ACTIVATIONS}, got "
                            f"{kwargs['activation_fn']!r}")
    arch = _field(kwargs, "net_arch", path, (dict, list))
    layers = [arch.get("pi"), arch.get("vf")] if isinstance(arch, dict) else [arch]
    if (isinstance(arch, dict) and set(arch) != {"pi", "vf"}) or not all(
            isinstance(widths, list) and all(type(w) is int and w >= 1 for w in widths)
            for widths in layers):
        raise LearningError(path, "policy_kwargs.net_arch", f"must be a list of positive "
                            f"widths or {{\"pi\": [...], \"vf\": [...]}}, got {arch!r}")
    _field(kwargs, "log_std_init", path, (float, int))
    _field(kwargs, "share_features_extractor", path, bool)
    for key in ("num_timesteps", "n_updates"):
        _field(record, key, path, int)
    arrays = read_arrays(folder / WEIGHTS_FILE)
    for space in _SPACES:
        for bound in ("low", "high"):
            if f"{space}.{bound}" not in arrays:
                raise LearningError(folder / WEIGHTS_FILE, f"{space}.{bound}", "missing")
    if "base_policy" in record:
        _check_base_policy(record["base_policy"], len(arrays["action_space.low"]), path)
    return record, arrays


def _check_base_policy(base: Any, action_dims: int, path: Path) -> None:
    """A policy file's ``base_policy``: a demonstrator's ``name`` and the entries of its
    action the network gives (``learned``, indices)."""
    from envs.policies import DEMONSTRATORS

    if _field(base, "name", path, str) not in DEMONSTRATORS:
        raise LearningError(path, "base_policy.name", f"one of {', '.join(DEMONSTRATORS)}, "
                            f"got {base['name']!r}")
    learned = _field(base, "learned", path, list)
    if not learned or not all(type(i) is int and 0 <= i < action_dims for i in learned):
        raise LearningError(path, "base_policy.learned", f"must be action indices below "
                            f"{action_dims}, got {learned!r}")


def build_policy(record: dict[str, Any], arrays: dict[str, np.ndarray], path: Path
                 ) -> ActorCriticPolicy:
    """The policy network of a :func:`read_policy` result, its weights loaded (in eval
    mode, on the CPU).

    Raises:
        LearningError: weights that do not fit the architecture, naming ``path``.
    """
    import gymnasium as gym
    import torch
    from stable_baselines3.common.policies import ActorCriticPolicy

    spaces = [gym.spaces.Box(arrays[f"{space}.low"], arrays[f"{space}.high"],
                             dtype=np.dtype(record.get("dtypes", {}).get(space, "float32")))
              for space in _SPACES]
    kwargs = dict(record["policy_kwargs"])
    kwargs["activation_fn"] = getattr(torch.nn, kwargs["activation_fn"])
    policy = ActorCriticPolicy(*spaces, lr_schedule=lambda _progress: 0.0, **kwargs)
    weights = {name.removeprefix("weights."): torch.as_tensor(value)
               for name, value in arrays.items() if name.startswith("weights.")}
    try:
        policy.load_state_dict(weights, strict=True)
    except RuntimeError as exc:
        first_line = (str(exc).strip().splitlines() or [""])[0]
        raise LearningError(path / WEIGHTS_FILE, None, f"weights that do not fit "
                            f"{POLICY_FILE}'s architecture: {first_line}") from None
    policy.set_training_mode(False)
    return policy


def restore_training(model: PPO, folder: Path) -> None:
    """Load ``folder``'s weights, Adam state and counters into ``model`` (built with the
    run's hyper-parameters), for a resume.

    Raises:
        LearningError: as :func:`read_policy`, or an optimizer state that does not fit.
    """
    import torch

    record, arrays = read_policy(folder)
    template = build_policy(record, arrays, folder)
    model.policy.load_state_dict(template.state_dict(), strict=True)
    saved = read_arrays(folder / OPTIMIZER_FILE)
    try:
        # JSON turned the tuples of a group (Adam's betas) into lists: back, but the params.
        groups = [{key: value if key == "params" or not isinstance(value, list)
                   else tuple(value) for key, value in group.items()}
                  for group in json.loads(str(saved.pop("param_groups")))]
        state: dict[int, dict[str, Any]] = {}
        for name, value in saved.items():
            _, index, key = name.split(".", 2)
            state.setdefault(int(index), {})[key] = torch.as_tensor(value)
        model.policy.optimizer.load_state_dict({"state": state, "param_groups": groups})
    except (KeyError, ValueError, TypeError, json.JSONDecodeError) as exc:
        raise LearningError(folder / OPTIMIZER_FILE, None, f"not this policy's optimizer "
                            f"state: {type(exc).__name__}: {exc}") from None
    model.num_timesteps = record["num_timesteps"]
    model._n_updates = record["n_updates"]
