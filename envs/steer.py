"""Steering the blade by feel when perception is wrong: ``musclecell/Steer-v2``.

The knife's path is planned from a perceived interface that is off by errors of the size the
cell's perception makes on unseen shapes (the benchmarks page: millimetres at depth from the
interface's lean, up to about a centimetre at the entry, where the guideline's walk starts on
the meat's tapered end, under a millimetre mid-cut). The policy sees what ``Cut-v2``'s sees
(the tip against the wrong path, the knife's force and torque, its progress, the path ahead)
and corrects across and in depth; the score is the tip's mean distance to the true interface
over the cut (:class:`cell.sim.score.CutScore`). ``Steer-v2``'s observation adds the knife's
force low-passed: one step's reading is noisy and jerks where the tissue tears, and where the
blade runs shows in the load it holds.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from cell.config import require_non_negative, require_positive
from cell.errors import InputError
from cell.sim.episode import Episode
from cell.sim.score import CutScore
from envs.observation import OBSERVATION_NAMES
from envs.params import ActionLimits
from envs.settings import parameters
from envs.tasks import CutEnv

#: The knife's action limits of the task: ``Cut-v2``'s, but the across offset's bound, which
#: the path's errors need (its entry's error and its lean at the meat's depth reach about a
#: centimetre).
STEER_LIMITS = ActionLimits(knife_max_across_m=0.012)
#: The stream of an episode's seed that draws its path error (the cell's own streams are
#: 0 and 1).
_PATH_ERROR_STREAM = 7
#: The knife's force entries of the observation (10 N, the sensor's frame).
_KNIFE_FORCE = slice(OBSERVATION_NAMES.index("knife_fx"), OBSERVATION_NAMES.index("knife_fz") + 1)


@dataclass(frozen=True)
class PathError:
    """The perceived interface's error against the true one, drawn per world: ``across_m``
    all along, ``entry_across_m`` and ``entry_height_m`` at the entry fading over ``fade_m``
    along the cut, and a lean error ``lean`` (the across error grows by ``lean`` per metre of
    depth below the meat's top); each a normal draw with that standard deviation (m, or
    dimensionless for the lean), clipped to ``clip`` of them. The entry's error across is
    smaller than the perception's worst (about a centimetre on tuning shapes): the knife enters
    on the scripted approach, before the policy acts, and a blade entering the meat's end
    several millimetres into a muscle trips the protective stop.

    Example:
        >>> error = PathError().draw(np.random.default_rng(0))
        >>> sorted(error)
        ['across_m', 'entry_across_m', 'entry_height_m', 'lean']
    """

    across_m: float = 0.001
    entry_across_m: float = 0.002
    entry_height_m: float = 0.002
    fade_m: float = 0.05
    lean: float = 0.04
    clip: float = 2.5

    def __post_init__(self) -> None:
        require_non_negative(self, "across_m", "entry_across_m", "entry_height_m", "lean")
        require_positive(self, "fade_m", "clip")

    def draw(self, rng: np.random.Generator) -> dict[str, float]:
        """One world's errors (m; the lean dimensionless)."""
        names = ("across_m", "entry_across_m", "entry_height_m", "lean")
        scale = np.array([getattr(self, name) for name in names])
        values = scale * np.clip(rng.standard_normal(len(names)), -self.clip, self.clip)
        return dict(zip(names, map(float, values), strict=True))


@dataclass(frozen=True)
class SteerParams:
    """The task's settings: the perception's ``path_error``, the reward's weight on the
    tip's distance across from the true interface while the knife cuts, per cm per control
    step (``off_interface_per_cm``), and the time constants (s) of the first-order low-pass
    filters of the knife's force whose outputs the observation adds (``load_filters_s``;
    none in ``Steer-v1``, :data:`STEER_V2`'s in ``Steer-v2``).

    Example:
        >>> SteerParams().path_error.entry_across_m
        0.002
        >>> STEER_V2.load_filters_s
        (0.1, 0.5)
    """

    path_error: PathError = field(default_factory=PathError)
    off_interface_per_cm: float = 0.02
    load_filters_s: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        require_non_negative(self, "off_interface_per_cm")
        taus = self.load_filters_s
        if not (isinstance(taus, (tuple, list)) and all(
                isinstance(tau, (int, float)) and not isinstance(tau, bool)
                and 0.0 < tau < np.inf for tau in taus)):
            raise InputError(None, "steer.load_filters_s", f"need a list of time constants, "
                             f"each > 0 s and finite, got {taus!r}")
        object.__setattr__(self, "load_filters_s", tuple(map(float, taus)))  # a JSON list too

    @property
    def load_names(self) -> tuple[str, ...]:
        """The names of the observation's entries the filters add (per filter, the force's
        x, y and z in 10 N, the sensor's frame)."""
        return tuple(f"knife_f{axis}_lowpass_{tau:g}s" for tau in self.load_filters_s
                     for axis in "xyz")


#: ``Steer-v2``'s settings: ``Steer-v1``'s, and the knife's force low-passed over 0.1 s and
#: 0.5 s in the observation.
STEER_V2 = SteerParams(load_filters_s=(0.1, 0.5))


@dataclass(frozen=True)
class _Guideline:
    points_m: np.ndarray


@dataclass(frozen=True)
class SkewedPerception:
    """What a wrong perception hands the planner: the guideline (``guideline.points_m``,
    (K, 3), m) and the interface as ``interface_y(x, z)`` (m), each off the truth by an
    error ``across(x, z)`` and ``height(x)`` (m)."""

    guideline: _Guideline
    interface_y: Callable[[np.ndarray, np.ndarray], np.ndarray]
    across: Callable[[np.ndarray, np.ndarray], np.ndarray]


def skewed_perception(episode: Episode, error: Mapping[str, float], fade_m: float
                      ) -> SkewedPerception:
    """The true interface of ``episode``'s meat moved by one world's ``error``
    (:meth:`PathError.draw`), the entry's part fading over ``fade_m`` from the meat's -x
    end (where the knife enters)."""
    mesh = episode.scene.mesh
    top = np.asarray(mesh.top_line, float)
    order = np.argsort(top[:, 0])
    top_x, top_z = top[order, 0], top[order, 2]

    def fading(x: np.ndarray) -> np.ndarray:
        return np.exp(-np.maximum(np.asarray(x, float) - top_x[0], 0.0) / fade_m)

    def across(x: np.ndarray, z: np.ndarray) -> np.ndarray:
        depth = np.maximum(np.interp(x, top_x, top_z) - np.asarray(z, float), 0.0)
        return error["across_m"] + error["entry_across_m"] * fading(x) + error["lean"] * depth

    def interface_y(x: np.ndarray, z: np.ndarray) -> np.ndarray:
        return mesh.interface_y(x, z) + across(x, z)

    guideline = top + np.stack([np.zeros(len(top)), across(top[:, 0], top[:, 2]),
                                error["entry_height_m"] * fading(top[:, 0])], axis=1)
    return SkewedPerception(_Guideline(guideline), interface_y, across)


class SteerEnv(CutEnv):
    """Steer the knife onto the interface by feel when the perceived path is wrong
    (``musclecell/Steer-v2``).

    .. rubric:: Description

    :class:`~envs.tasks.CutEnv` (its task, scripted pull and randomised worlds) whose
    knife path is planned from a perceived interface off the true one by
    :class:`PathError`: across all along, more at the entry (fading over 5 cm), a lean error
    that grows with depth, and the guideline's height at the entry. The path a policy sees
    is the wrong one; the knife's force and torque say where the blade runs.

    .. rubric:: Action space

    ``Cut-v2``'s: ``Box(-1, 1, (4,), float32)`` (along speed, across, depth, yaw), the
    across offset's bound 12 mm (:data:`STEER_LIMITS`).

    .. rubric:: Observation space

    ``Cut-v2``'s 35 entries, measured against the wrong path; ``Steer-v2`` adds six: the
    knife's force (10 N, the sensor's frame) through first-order low-pass filters of time
    constants 0.1 s and 0.5 s, each starting at the force read at the hand-over
    (``knife_fx_lowpass_0.1s`` to ``knife_fz_lowpass_0.5s``; the env's
    ``observation_names``).

    .. rubric:: Rewards

    ``Cut-v2``'s terms and ``off_interface``: ``-off_interface_per_cm`` times the tip's
    distance across from the true interface (cm) each step while the knife cuts.

    .. rubric:: Starting state

    As ``Cut-v2``'s, the knife in at the entry of the wrong path.

    .. rubric:: Episode end

    As ``Cut-v2``'s. The final step's info adds ``tip_distance_mean_m`` and
    ``tip_distance_max_m`` (the tip's distance to the true, deforming interface over the
    cut: :class:`~cell.sim.score.CutScore`; None when the tip never came across from
    it) and ``path_error`` (the world's draw).

    .. rubric:: Arguments

    ``Cut-v2``'s, and ``steer`` (a :class:`SteerParams`, or a mapping of its fields over
    the version's: :data:`STEER_V2` for ``Steer-v2``).

    .. rubric:: Version history

    - v2: the observation adds the knife's force low-passed over 0.1 s and 0.5 s; the
      worlds, paths and rollouts are v1's.
    - v1: the first version.

    Example:
        >>> import gymnasium, envs
        >>> env = gymnasium.make("musclecell/Steer-v2", time_limit_s=0.1)
        >>> obs, info = env.reset(seed=0)
        >>> sorted(env.unwrapped.path_error)
        ['across_m', 'entry_across_m', 'entry_height_m', 'lean']
        >>> obs.shape, env.unwrapped.observation_names[-1]
        ((41,), 'knife_fz_lowpass_0.5s')
    """

    def __init__(self, steer: SteerParams | Mapping[str, Any] | None = None,
                 **kwargs: Any) -> None:
        self.steer = parameters(SteerParams, steer, "steer")
        self.path_error: dict[str, float] = {}
        self._perceived: SkewedPerception | None = None
        kwargs["limits"] = parameters(ActionLimits, kwargs.get("limits"), "limits",
                                      STEER_LIMITS)
        super().__init__(**kwargs)
        self.observation_names = (*self.observation_names, *self.steer.load_names)
        self.observation_space = gym.spaces.Box(
            self.observation_space.low[0], self.observation_space.high[0],
            (len(self.observation_names),), np.float32)
        self._load_taus_s = np.asarray(self.steer.load_filters_s, float)[:, None]
        self._loads: np.ndarray | None = None

    def _planned_from(self, episode: Episode, perceived: Any) -> SkewedPerception:
        rng = np.random.default_rng([episode.scenario.seed, _PATH_ERROR_STREAM])
        self.path_error = self.steer.path_error.draw(rng)
        self._perceived = skewed_perception(episode, self.path_error,
                                            self.steer.path_error.fade_m)
        return self._perceived

    def _start(self, scenario: Any) -> None:
        self._loads = None
        super()._start(scenario)
        episode = self.episode
        self._score = CutScore(episode.scene.aponeurosis, episode.scene.mesh,
                               episode.scenario.knife.blade_length_m,
                               episode.scenario.knife.blade_thickness_m)

    def _observation(self) -> np.ndarray:
        obs = super()._observation()
        if not self._load_taus_s.size:
            return obs
        load = obs[_KNIFE_FORCE]
        if self._loads is None:  # the hand-over's reading: no step before it to filter
            self._loads = np.tile(load, (self._load_taus_s.size, 1))
        else:
            gain = self._dt_s / (self._load_taus_s + self._dt_s)  # backward Euler, stable
            self._loads = self._loads + gain * (load - self._loads)
        return np.concatenate([obs, self._loads.ravel()]).astype(np.float32)

    def across_to_interface_m(self) -> float:
        """How far across the path (its frame's y, m) the true interface lies from the
        perceived one at the tip: the offset a controller that knows the truth steers to
        (the ceiling's privilege)."""
        tip = self._reading.tip_m
        error_y = float(self._perceived.across(tip[:1], tip[2:])[0])  # perceived less true
        return -error_y * float(self._knife.path_pose()[1][1, 1])

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """``Cut-v2``'s step, the tip scored against the true interface while it cuts."""
        cutting = self.episode is not None and self._knife.progress < 1.0
        obs, reward, terminated, truncated, info = super().step(action)
        if cutting and not self.diverged:
            reading = self._reading
            self._score.observe(self.episode.sim.data, 0, reading.tip_m,
                                reading.blade_rotation[:, 2])
            penalty = self.steer.off_interface_per_cm * 100.0 * reading.interface_offset_m
            info["reward_terms"]["off_interface"] = -penalty
            reward -= penalty
        if terminated or truncated:
            distance = self._score.tip_distance()
            info.update(tip_distance_mean_m=distance["mean"],
                        tip_distance_max_m=distance["max"], path_error=dict(self.path_error))
        return obs, reward, terminated, truncated, info


def make_steer_v2(**kwargs: Any) -> SteerEnv:
    """``musclecell/Steer-v2``: a :class:`SteerEnv` whose ``steer`` settings are
    :data:`STEER_V2` with the given mapping's fields.

    Example:
        >>> env = make_steer_v2(steer={"off_interface_per_cm": 0.0}, time_limit_s=0.1)
        >>> env.steer.load_filters_s, env.steer.off_interface_per_cm
        ((0.1, 0.5), 0.0)
    """
    kwargs["steer"] = parameters(SteerParams, kwargs.get("steer"), "steer", STEER_V2)
    return SteerEnv(**kwargs)
