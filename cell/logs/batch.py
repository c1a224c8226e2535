"""A batch of separation logs (docs/logs.md): several separations of one batch of meat,
which share their tools, sensors and material (their meat's shapes may differ). Read
together, each log with its scenario, and refused with a named error when they do not share
them: the batch diagnosis compares them as separations of one meat.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cell.errors import LogBatchError
from cell.measure.logs import SeparationLog, read_log
from cell.sim.scenario import Scenario, load_scenario

#: What the logs of a batch share: the name the error gives -> the part of a log and its
#: scenario, by the keys that name it (``log.toml``'s for the log's own ``sensors``).
SHARED: dict[str, Callable[[SeparationLog, Scenario], dict[str, Any]]] = {
    "tools": lambda log, scenario: {"knife": scenario.knife, "gripper": scenario.gripper,
                                    "fixture": scenario.fixture},
    "sensors": lambda log, scenario: {
        "sensors": scenario.sensors,
        "log.toml sensors": {key: value for key, value in log.sensors.items()
                             if key.endswith("_rate_hz")}},
    "material": lambda log, scenario: {"material": scenario.material},
}


@dataclass(frozen=True)
class LogBatch:
    """Separation logs of one batch of meat, each with the scenario it names.

    Attributes:
        logs: the logs, in the order given.
        scenarios: each log's scenario, read from its file, with the log's seed.

    Example:
        >>> read_log_batch(["one/log"])
        Traceback (most recent call last):
        cell.errors.LogBatchError: logs: a batch needs at least two logs, got 1
    """

    logs: tuple[SeparationLog, ...]
    scenarios: tuple[Scenario, ...]


def read_log_batch(folders: Sequence[str | Path]) -> LogBatch:
    """Read the logs in ``folders`` as one batch.

    Raises:
        LogError: a log that cannot be read (:func:`~cell.measure.logs.read_log`).
        ScenarioError: a log's scenario file that cannot be read.
        LogBatchError: fewer than two logs, a log given twice, or logs whose tools,
            sensors or material differ: it names the second log's file and the first key
            that differs.
    """
    if len(folders) < 2:
        raise LogBatchError(None, "logs", f"a batch needs at least two logs, got {len(folders)}")
    resolved = [Path(folder).resolve() for folder in folders]
    for index, folder in enumerate(resolved):
        if folder in resolved[:index]:
            raise LogBatchError(Path(folders[index]) / "log.toml", None,
                                "this log is given twice")
    logs = tuple(read_log(folder) for folder in folders)
    scenarios = tuple(log_scenario(log) for log in logs)
    first = logs[0]
    for log, scenario in zip(logs[1:], scenarios[1:], strict=True):
        for what, part in SHARED.items():
            key = _first_difference(part(first, scenarios[0]), part(log, scenario))
            if key is not None:
                file = log.folder / "log.toml" if key.startswith("log.toml") else log.scenario
                raise LogBatchError(file, key.removeprefix("log.toml "),
                                    f"the logs of one batch share their {what}: this log's "
                                    f"differ from those of {first.folder}")
    return LogBatch(logs, scenarios)


def log_scenario(log: SeparationLog) -> Scenario:
    """The scenario ``log`` names, with the seed it ran with.

    Raises:
        ScenarioError: the scenario file cannot be read.
    """
    scenario = load_scenario(log.scenario)
    return scenario if log.seed is None else dataclasses.replace(scenario, seed=log.seed)


def _first_difference(a: Any, b: Any, key: str = "") -> str | None:
    """The dotted key of the first value that differs between ``a`` and ``b`` (nested
    dictionaries and dataclasses), or None."""
    if dataclasses.is_dataclass(a) and type(a) is type(b):
        a, b = ({f.name: getattr(x, f.name) for f in dataclasses.fields(x)} for x in (a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        for name in sorted(set(a) | set(b), key=str):
            inner = f"{key}.{name}" if key else str(name)
            if name not in a or name not in b:
                return inner
            found = _first_difference(a[name], b[name], inner)
            if found is not None:
                return found
        return None
    return None if _same(a, b) else (key or "value")


def _same(a: Any, b: Any) -> bool:
    try:
        return bool(a == b)
    except ValueError:  # arrays compare element-wise
        return bool(np.array_equal(a, b))
