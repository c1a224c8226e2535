"""The one-way conversion of a run saved by an earlier release (Stable-Baselines3's
``policy.zip`` and a pickled ``vecnormalize.pkl``) to the numbers-and-JSON files of
:mod:`cell.learning.policyfile`: ``musclecell convert-policy RUN --trust-pickle``.

Converting unpickles the old files, which runs whatever code they hold: it is the only place
the project loads a pickle, and it needs the explicit ``trust_pickle``. The pickled files are
left where they are (the new files take precedence; delete the old ones once converted).
"""

from __future__ import annotations

import pickle
import zipfile
from pathlib import Path
from typing import Any

from cell.errors import LearningError
from cell.io import read_json
from cell.learning.policyfile import PICKLED_FILES, WEIGHTS_FILE, save_policy

ZIP_FILE, PICKLE_FILE = PICKLED_FILES
#: The file of a run (top level) and of a checkpoint that names the env.
RUN_RECORDS = ("learn.json", "state.json")


def load_saved_policy(path: Path, **kwargs: Any) -> Any:
    """The PPO model of an earlier release's ``policy.zip`` (``kwargs`` go to ``PPO.load``),
    which unpickles its entries: only for files you trust.

    Raises:
        LearningError: naming ``path`` when it is not a saved policy (a broken or foreign
            zip).
    """
    from stable_baselines3 import PPO

    try:
        return PPO.load(path, device="cpu", **kwargs)
    except (OSError, ValueError, KeyError, EOFError, RuntimeError, zipfile.BadZipFile,
            pickle.UnpicklingError) as exc:
        first_line = (str(exc).strip().splitlines() or [""])[0]
        raise LearningError(path, None, f"not a saved policy: {type(exc).__name__}: "
                            f"{first_line}") from None


def load_pickled_normalization(path: Path) -> Any:
    """The ``VecNormalize`` pickled at ``path``: only for files you trust.

    Raises:
        LearningError: naming ``path`` when it is not such a file.
    """
    try:
        with path.open("rb") as file:
            return pickle.load(file)
    except (OSError, EOFError, AttributeError, ImportError, IndexError,
            pickle.UnpicklingError) as exc:
        raise LearningError(path, None, f"not saved observation statistics: "
                            f"{type(exc).__name__}: {exc}") from None


def pickled_folders(run: Path) -> list[Path]:
    """``run`` and its checkpoint folders that hold the pickled files and no converted ones."""
    candidates = [run, *sorted((run / "checkpoints").glob("*/"))]
    return [folder for folder in candidates
            if all((folder / name).is_file() for name in PICKLED_FILES)
            and not (folder / WEIGHTS_FILE).exists()]


def convert_run(run: Path, trust_pickle: bool) -> list[Path]:
    """Convert ``run`` and its checkpoints (see the module); returns the folders converted.

    Raises:
        LearningError: without ``trust_pickle``; nothing to convert; a folder without the
            record that names its env.
    """
    if not trust_pickle:
        raise LearningError(run, "--trust-pickle", "converting unpickles the run's files, "
                            "which runs any code they hold: give --trust-pickle only for a run "
                            "you trust")
    folders = pickled_folders(run)
    if not folders:
        raise LearningError(run, None, f"no {ZIP_FILE} with {PICKLE_FILE} to convert (or "
                            f"already converted)")
    for folder in folders:
        records = [folder / name for name in RUN_RECORDS if (folder / name).is_file()]
        if not records:
            raise LearningError(folder, None, f"no {' or '.join(RUN_RECORDS)} to name the env")
        env_id = read_json(records[0], LearningError).get("env_id")
        if not isinstance(env_id, str):
            raise LearningError(records[0], "env_id", "missing")
        model = load_saved_policy(folder / ZIP_FILE)
        save_policy(folder, model, load_pickled_normalization(folder / PICKLE_FILE), env_id)
    return folders
