"""Fuzzing separation logs (docs/logs.md): ``log.toml`` of random tables, keys and values,
channel files of shuffled, dropped and stray columns, numbers (NaN, infinities, 1e308, text),
quaternions off unit, time that stalls, blank and comment lines, missing files and binary
junk. Reading must return a sound log or raise a :class:`~cell.errors.LogError` naming the
log's file and the key or line and column at fault, never another exception
(:mod:`tests.fuzzing`); a log made sure to be bad is refused by ``musclecell replay``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import strategies as st

from cell.errors import LogError
from cell.measure.logs import FORCE, POSE, QUATERNION_TOLERANCE, TORQUE, read_log
from tests.fuzzing import (
    cells,
    documents,
    fuzz_tests,
    mostly,
    numbers,
    scratch,
    tables,
    toml_document,
    values,
    written,
)
from tests.refusals import refused

#: Each table of ``log.toml`` and its keys.
LOG_KEYS = {"log": ("name", "scenario", "seed"),
            "sensors": ("knife_rate_hz", "fixture_rate_hz", "knife_tare_s"),
            "phases": ("cut_s",), "outcome": ("bindings", "released", "torn")}
#: Faults of a whole file, which name the file alone (a TOML error names its line itself).
WHOLE_FILE = ("not valid TOML", "no header line", "missing channel", "no samples",
              "file not found", "not UTF-8", "not text")


def _log_value(table: str, key: str) -> st.SearchStrategy[Any]:
    good = {"scenario": st.just("scenario.toml"), "name": st.just("fuzz"),
            "seed": st.integers(0, 9),
            "cut_s": st.lists(st.lists(st.floats(0.0, 1.0), min_size=2, max_size=2)
                              .map(sorted), max_size=2)}
    return mostly(good.get(key, st.floats(0.0, 100.0) | st.integers(0, 50)),
                  values() | numbers())


def _log_document() -> st.SearchStrategy[dict[str, Any]]:
    sound = st.fixed_dictionaries(
        {table: st.fixed_dictionaries({key: _log_value(table, key) for key in keys})
         for table, keys in LOG_KEYS.items()})
    return mostly(sound, documents(LOG_KEYS, _log_value), 4)


def _channel(pose: bool, grasp: bool) -> st.SearchStrategy[str]:
    columns = ("time_s", *(POSE if pose else ()), *FORCE, *TORQUE, *(("grasp",) if grasp
                                                                     else ()))
    special = {"qw": mostly(st.just("1.0"), cells(), 30),
               **{q: mostly(st.just("0.0"), cells(), 30) for q in POSE[4:]},
               "grasp": mostly(st.sampled_from(["0", "1"]), cells(), 30)}
    return tables(columns, special, "time_s")


@st.composite
def logs(draw: st.DrawFn) -> dict[str, str | bytes]:
    """A log folder's files: mostly all of them, each mostly well formed, rarely binary junk
    or left out."""
    files: dict[str, str | bytes] = {
        "scenario.toml": "", "log.toml": toml_document(draw(_log_document())),
        "knife.csv": draw(_channel(True, False)), "gripper.csv": draw(_channel(True, True)),
        "fixture.csv": draw(_channel(False, False))}
    for name in ("log.toml", "knife.csv", "gripper.csv", "fixture.csv"):
        fault = draw(mostly(st.just(None), st.sampled_from(["junk", "gone"]), 20))
        if fault == "junk":
            files[name] = b"\xff\xfe\x00" + draw(st.binary(max_size=20))
        elif fault == "gone":
            del files[name]
    return files


def _check_log(files: dict[str, str | bytes]) -> None:
    with scratch() as folder:
        root = written(Path(folder) / "log", files)
        try:
            log = read_log(root)
        except LogError as error:
            assert Path(error.file).parent == root, error
            assert Path(error.file).name in files or "missing" in error.message \
                or "not found" in error.message, error
            assert error.field or error.message.startswith(WHOLE_FILE), error
            return
        for channel in log.channels.values():
            assert np.all(np.diff(channel.time_s) > 0) and np.all(np.isfinite(channel.force_n))
            if channel.quaternion is not None:
                norm = np.linalg.norm(channel.quaternion, axis=1)
                assert np.all(np.abs(norm - 1.0) <= QUATERNION_TOLERANCE)


test_logs, test_logs_slow = fuzz_tests(logs(), _check_log, 15)


def _check_cli_log(files: dict[str, str | bytes]) -> None:
    """A fuzzed log made sure to be bad (a knife sample at a time before the first):
    ``replay`` exits 2 naming a file of the log, no traceback, the folder as it was."""
    files = {**files, "knife.csv": "time_s\n1.0\n0.5\n"} if isinstance(
        files.get("knife.csv"), str) else files
    with scratch() as folder:
        cwd = Path(folder)
        written(cwd, {**{f"log/{name}": text for name, text in files.items()},
                      "out/kept.txt": "before\n"})
        refused(cwd, "replay", "log", "--out", "out/replay", words=("log/",))


_, test_cli_logs_slow = fuzz_tests(logs(), _check_cli_log, 1, slow_examples=30)
