"""Hidden-effect log batches: separations of one batch of meat, run by the cell in a world
with hidden changes and written as separation logs (:mod:`cell.sim.episodelog`), the truth
returned and never written.

A batch is a folder with the lab's material file (``material.toml``) and :data:`LOG_COUNT`
logs (``log-1``, ...), each with the scenario the lab believes (the base scenario with that
log's meat shape, naming ``../material.toml``). Each log's meat shape is drawn about the
base's (length, round's width and height, the interface's bow); its episode has a seed of
its own, so its sensors' noise differs. The world the cell runs differs from the belief by
the hidden causes of the log diagnosis's registry (:mod:`cell.logs.causes`, every cause of
:func:`hidden_causes`), with drawn magnitudes, the same for every log of the batch: a world
cause's factor (or angle) drawn within its ``typical`` range, either way; ``sensor_offset``
a constant force added to one channel (:data:`~cell.measure.logs.CHANNELS`). The world's
changes are those the batch diagnosis fits, so that a fitted magnitude compares with the
truth, and a cause added to the registry can be hidden with nothing edited here.

The files say that the batch is synthetic and hold nothing of the truth (compare
:mod:`cell.synthetic.cut` for cut sets).

Example:
    >>> import tempfile
    >>> from pathlib import Path
    >>> folder = Path(tempfile.mkdtemp()) / "batch"
    >>> truth = write_hidden_log_batch(folder, seed=1, base="scenarios/quick.toml",
    ...                                causes=("tissue_stiffness",), logs=1, end_s=0.04)
    >>> truth.causes, sorted(p.name for p in (folder / "log-1").iterdir())[:3]
    (('tissue_stiffness',), ['fixture.csv', 'gripper.csv', 'knife.csv'])
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from cell.config import read_toml
from cell.errors import LogError
from cell.logs.causes import CAUSES, SENSOR_OFFSET, applicable, changed_world
from cell.measure.logs import CHANNELS
from cell.outputs import write_atomic
from cell.sim.episodelog import LoggedEpisode, write_log
from cell.sim.scenario import Scenario, load_scenario
from cell.sim.scenariotoml import resolved_tables, tables_toml
from cell.tissue.material import MassSpringMaterial
from cell.tissue.materialfile import material_to_toml

#: The world causes drawn from the seed's first stream, in this order (those the generator
#: had before later causes got a stream of their own, so that old seeds keep their batches);
#: every other cause of the registry draws from the second stream, in the registry's order.
_FIRST_STREAM = ("binding_strength", "tearing_threshold", "tissue_stiffness", "fibre_direction")
#: Logs per batch.
LOG_COUNT = 3
#: The meat shape's drawn keys and the range of their factor on the base's value.
SHAPE_FACTORS = {"length_m": (0.85, 1.15), "round_width_m": (0.9, 1.1),
                 "round_height_m": (0.9, 1.1), "interface_bow_m": (0.5, 1.5)}
_HEADER = ("Synthetic separation log (musclecell, cell/synthetic/logs.py): the cell as the lab "
           "believes it,\nthis log's meat shape; a world with hidden changes ran it.")


@dataclass(frozen=True)
class LogBatchTruth:
    """The answer key of one hidden-effect log batch (never written into the batch).

    Attributes:
        causes: the hidden causes, in :func:`hidden_causes`' order (none: the belief's world).
        seed: the seed everything was drawn from.
        magnitudes: each hidden cause's drawn magnitude: a factor, an angle in rad (a cause
            of kind ``"angle"``), or the offset channel's force, N (``sensor_offset``).
        offset_channel: the channel ``sensor_offset`` changes ("" without it).
        shapes: each log's drawn meat shape (the keys of :data:`SHAPE_FACTORS`, m).
        wall_s: wall-clock time of the batch's episodes, s.
    """

    causes: tuple[str, ...]
    seed: int
    magnitudes: dict[str, Any]
    offset_channel: str
    shapes: tuple[dict[str, float], ...]
    wall_s: float

    def to_json(self) -> str:
        """The truth as JSON text, to be kept apart from the batch."""
        return json.dumps(self.__dict__, indent=2, default=list) + "\n"


def hidden_causes() -> tuple[str, ...]:
    """The causes this generator can hide: every world cause of the registry
    (:data:`~cell.logs.causes.CAUSES`) and ``sensor_offset``."""
    return (*CAUSES, SENSOR_OFFSET)


def _draw(cause: str, stream: np.random.Generator) -> float:
    """A magnitude of ``cause`` within its ``typical`` range, either way: a factor, or an
    angle in rad."""
    low, high = CAUSES[cause].typical
    if CAUSES[cause].kind == "angle":
        return float(stream.choice([-1.0, 1.0]) * np.radians(stream.uniform(low, high)))
    return float(np.exp(stream.choice([-1.0, 1.0]) * stream.uniform(np.log(low), np.log(high))))


def _draw_world(seed: int) -> tuple[dict[str, Any], str, np.random.Generator]:
    """Every cause's magnitude (drawn whether hidden or not, so that the other draws do not
    depend on which are hidden), and the stream the shapes and seeds are drawn from next."""
    rng, later = np.random.default_rng(seed), np.random.default_rng([seed, 1])
    magnitudes: dict[str, Any] = {cause: _draw(cause, rng) for cause in _FIRST_STREAM}
    offset = rng.normal(0.0, 1.0, 3)
    offset *= rng.uniform(0.5, 2.0) / np.linalg.norm(offset)
    magnitudes[SENSOR_OFFSET] = tuple(float(v) for v in offset)
    channel = str(rng.choice(list(CHANNELS)))
    magnitudes.update({cause: _draw(cause, later) for cause in CAUSES
                       if cause not in _FIRST_STREAM})
    return magnitudes, channel, rng


def world_changes(causes: Sequence[str], magnitudes: dict[str, Any]) -> dict[str, float]:
    """The hidden world causes as :func:`~cell.logs.causes.changed_world` takes them: the
    log of a factor, an angle (the sensor's offset is not a change of the world).

    Example:
        >>> world_changes(("tearing_threshold", "sensor_offset"),
        ...               {"tearing_threshold": 1.0, "sensor_offset": (0.0, 0.0, 1.0)})
        {'tearing_threshold': 0.0}
    """
    return {cause: (magnitudes[cause] if CAUSES[cause].kind == "angle"
                    else float(np.log(magnitudes[cause])))
            for cause in causes if cause != SENSOR_OFFSET}


def _check(causes: Sequence[str], scenario: Scenario, logs: int) -> tuple[str, ...]:
    known = hidden_causes()
    unknown = [c for c in causes if c not in known]
    if unknown or len(set(causes)) != len(causes):
        raise LogError(None, "causes", f"must be distinct causes of {known}, got "
                       f"{list(causes)}")
    if not isinstance(scenario.material, MassSpringMaterial):
        raise LogError(None, "material", "the generator writes mass-spring materials only")
    idle = [c for c in causes if c != SENSOR_OFFSET and c not in applicable(scenario)]
    if idle:
        raise LogError(None, "causes", f"{idle[0]} changes nothing in this scenario's world")
    if logs < 1:
        raise LogError(None, "logs", f"must be >= 1, got {logs}")
    return tuple(c for c in known if c in causes)


def write_hidden_log_batch(folder: Path, seed: int, base: str | Path,
                           causes: Sequence[str] = (), logs: int = LOG_COUNT,
                           end_s: float | None = None) -> LogBatchTruth:
    """Draw a batch from ``seed`` on the ``base`` scenario with ``causes`` hidden in it, run
    its episodes, write it into ``folder`` (created) and return its truth. ``end_s`` cuts
    every episode short (tests).

    Raises:
        LogError: unknown or repeated causes, a cause that changes nothing in the base's
            world, a material that is not mass-spring.
        ScenarioError: the base scenario cannot be read.
    """
    folder, base = Path(folder), Path(base)
    scenario = load_scenario(base)
    causes = _check(causes, scenario, logs)
    magnitudes, offset_channel, rng = _draw_world(seed)
    changes = world_changes(causes, magnitudes)
    raw = resolved_tables(read_toml(base), scenario)
    folder.mkdir(parents=True, exist_ok=True)
    write_atomic(folder / "material.toml", material_to_toml(scenario.material, _HEADER))
    shapes, wall_start = [], time.perf_counter()
    for k in range(1, logs + 1):
        shape = {key: float(getattr(scenario.tissue, key) * rng.uniform(low, high))
                 for key, (low, high) in SHAPE_FACTORS.items()}
        log_seed = int(rng.integers(0, 2**31))
        belief = replace(scenario, name=f"{scenario.name}-{k}", seed=log_seed, end_s=end_s,
                         tissue=replace(scenario.tissue, **shape))
        path = folder / f"log-{k}" / "scenario.toml"
        path.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(path, log_scenario_toml(raw, belief, shape, _HEADER))
        episode = LoggedEpisode(changed_world(belief, changes))
        episode.run()
        offset = ({offset_channel: np.asarray(magnitudes[SENSOR_OFFSET])}
                  if SENSOR_OFFSET in causes else {})
        write_log(path.parent, episode, path, offset)
        shapes.append(shape)
    hidden = {cause: magnitudes[cause] for cause in causes}
    return LogBatchTruth(causes, seed, hidden,
                         offset_channel if SENSOR_OFFSET in causes else "", tuple(shapes),
                         time.perf_counter() - wall_start)


def log_scenario_toml(raw: dict[str, Any], belief: Scenario, shape: dict[str, float],
                      header: str) -> str:
    """The base scenario's tables (``raw``) with this log's name, seed, end and ``shape``
    (its drawn keys), naming the batch's material file (``../material.toml``), ``header``'s
    lines on top."""
    tables = {**raw, "scenario": {**raw.get("scenario", {}), "name": belief.name,
                                  "seed": belief.seed},
              "tissue": {**raw.get("tissue", {}), **shape},
              "material": {"file": "../material.toml"}}
    if belief.end_s is not None:
        tables["scenario"]["end_s"] = belief.end_s
    return tables_toml(tables, header)
