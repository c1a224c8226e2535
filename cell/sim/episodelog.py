"""Writing separation logs (:mod:`cell.measure.logs`) from the cell's own episodes: the
sensors sampled at every control step, as a lab's cell would record them.

The readings are the sensors' own (:meth:`Simulation.read`: tared when the episode tares
them, with their bias and noise), the noise drawn from a stream of the seed of its own, so
that an episode with a log gives the same result as one without.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np

from cell.measure.logs import CHANNELS, Channel, channel_rows, log_toml
from cell.outputs import write_atomic, write_rows
from cell.perception.pipeline import PerceivedPlan
from cell.sim.assembly import Scene
from cell.sim.episode import Episode, EpisodePlan
from cell.sim.scenario import Scenario
from cell.sim.simulation import Simulation
from cell.sim.summary import EpisodeTrace

#: Which random stream of the seed the log's sensor noise draws from (the sensors use 0,
#: the camera 1, a replay's sensors 3).
LOG_STREAM = 2


def meat_on_sensor(reading: np.ndarray) -> np.ndarray:
    """A sensor's reading turned into the force (or torque) the meat exerts on it: the one
    place the log's sign is set. A force/torque sensor reads what its tool pulls on it (the
    load on the tool, minus); the fixture's reads what the world gives it to hold the round
    (the round's load, minus)."""
    return -np.asarray(reading)


class SensorSampler:
    """Samples the knife's, the gripper's and the fixture's sensors of ``sim``, one row per
    :meth:`sample`, into :class:`~cell.measure.logs.Channel` objects, the noise drawn from
    the random ``stream`` of the scenario's seed.

    Example:
        >>> from cell.sim.assembly import build_scene
        >>> from cell.tissue.geometry import MuscleShape
        >>> scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05))
        >>> sampler = SensorSampler(Simulation(build_scene(scenario), scenario))
        >>> sampler.sample(grasped=False)
        >>> sampler.channels()["knife"].quaternion.shape
        (1, 4)
    """

    def __init__(self, sim: Simulation, stream: int = LOG_STREAM) -> None:
        self.sim = sim
        self.rng = np.random.default_rng([sim.scenario.seed, stream])
        self._sites = {stem: int(sim.model.sensor(f"{stem}/force").objid[0])
                       for stem in CHANNELS if CHANNELS[stem]}
        self._rows: dict[str, list[np.ndarray]] = {stem: [] for stem in CHANNELS}
        self._grasp: list[int] = []

    def sample(self, grasped: bool) -> None:
        """One row of every channel at the simulation's present time."""
        sim, data = self.sim, self.sim.data
        time_s = np.array([sim.time_s])
        quaternion = np.zeros(4)
        for stem, site in self._sites.items():
            mujoco.mju_mat2Quat(quaternion, data.site_xmat[site])
            quaternion *= np.sign(quaternion[0]) or 1.0  # one of the two: w >= 0
            self._rows[stem].append(np.concatenate([
                time_s, data.site_xpos[site], quaternion,
                meat_on_sensor(sim.read(f"{stem}/force", self.rng)),
                meat_on_sensor(sim.read(f"{stem}/torque", self.rng))]))
        fixture = sim.model.sensor("fixture_force").objid[0]
        world = data.site_xmat[fixture].reshape(3, 3) @ sim.read("fixture_force", self.rng)
        self._rows["fixture"].append(np.concatenate([time_s, meat_on_sensor(world)]))
        self._grasp.append(int(grasped))

    def channels(self) -> dict[str, Channel]:
        """The samples so far, by channel."""
        out = {}
        for stem, rows in self._rows.items():
            table = np.array(rows).reshape(len(rows), -1)
            if CHANNELS[stem]:
                out[stem] = Channel(table[:, 0], table[:, 8:11], table[:, 11:14],
                                    table[:, 1:4], table[:, 4:8],
                                    np.array(self._grasp) if stem == "gripper" else None)
            else:
                out[stem] = Channel(table[:, 0], table[:, 1:4])
        return out


class LoggedEpisode(Episode):
    """The scripted episode, its sensors sampled at every control step (:class:`SensorSampler`)
    with the times the episode tared them and its plan's cut windows: what :func:`write_log`
    writes. Its result is the plain episode's.

    Example:
        >>> from dataclasses import replace
        >>> from cell.tissue.geometry import MuscleShape
        >>> scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05), end_s=0.1)
        >>> scenario = replace(scenario, perception=replace(scenario.perception, enabled=False))
        >>> episode = LoggedEpisode(scenario)
        >>> _ = episode.run()
        >>> len(episode.sampler.channels()["fixture"].time_s)  # one sample per control step
        5
    """

    def __init__(self, scenario: Scenario, scene: Scene | None = None) -> None:
        super().__init__(scenario, scene)
        self.sampler = SensorSampler(self.sim)
        self.tares_s: dict[str, float] = {}
        self.last_plan: EpisodePlan | None = None

    def plan(self, perceived: PerceivedPlan | None = None) -> EpisodePlan:
        """:meth:`Episode.plan`, kept for the log's cut windows."""
        self.last_plan = super().plan(perceived)
        return self.last_plan

    def _measure(self, trace: EpisodeTrace, knife_tared: bool, gripper_tared: bool) -> None:
        super()._measure(trace, knife_tared, gripper_tared)
        time_s = self.sim.time_s
        if knife_tared:
            self.tares_s.setdefault("knife_tare_s", time_s)
        if gripper_tared:
            self.tares_s.setdefault("gripper_tare_s", time_s)
            self.tares_s.setdefault("fixture_tare_s", time_s)
        self.sampler.sample(self._grasped)

    def cut_windows_s(self) -> tuple[tuple[float, float], ...]:
        """When the knife cut, per pass, s (none before :meth:`plan`)."""
        if self.last_plan is None or not self.scenario.cut.enabled:
            return ()
        return tuple((w.start_s, w.end_s) for w in self.last_plan.passes.windows_s)


def write_log(folder: str | Path, episode: LoggedEpisode, scenario_path: str | Path,
              force_offset_n: dict[str, np.ndarray] | None = None) -> Path:
    """Write the log of the episode that ran (``scenario_path``: its scenario file, which
    ``log.toml`` names by its path from the log's folder): each file through a temporary one
    renamed into place, ``log.toml`` last. ``force_offset_n``: a force (N, the channel's
    frame) added to every sample of the channels it names (a sensor's hidden offset,
    :mod:`cell.synthetic.logs`)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    offsets = force_offset_n or {}
    for stem, channel in episode.sampler.channels().items():
        if stem in offsets:
            channel = replace(channel, force_n=channel.force_n + offsets[stem])
        write_rows(folder / f"{stem}.csv", *channel_rows(channel))
    rate = episode.scenario.simulation.control_rate_hz
    sensors = {f"{stem}_rate_hz": float(rate) for stem in CHANNELS} | episode.tares_s
    scenario = os.path.relpath(Path(scenario_path).resolve(), folder.resolve())
    text = log_toml(f"{episode.scenario.name}-{episode.scenario.seed}",
                    Path(scenario).as_posix(), episode.scenario.seed, sensors,
                    episode.cut_windows_s(), _outcome(episode))
    return write_atomic(folder / "log.toml", text).parent


def _outcome(episode: Episode) -> dict[str, int]:
    """The bindings, how many the episode released and how many of them tore."""
    apo = episode.scene.aponeurosis
    counts = apo.released_counts()
    return {"bindings": len(apo), "released": int(sum(counts.values())),
            "torn": int(counts["tearing"])}
