"""Policies without a deep-learning dependency: the scripted plan, and a linear policy with
the cross-entropy search that tunes it."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import gymnasium as gym
import numpy as np

from envs.observation import OBSERVATION_NAMES
from envs.params import ActionLimits
from envs.registration import DEPRECATED_IDS
from envs.separation import MuscleSeparationEnv

_TIP_HEIGHT = OBSERVATION_NAMES.index("tip_height_cm")
_TIP_DEPTH = OBSERVATION_NAMES.index("tip_depth_cm")
_PROGRESS = OBSERVATION_NAMES.index("path_progress")
_KNIFE_FY = OBSERVATION_NAMES.index("knife_fy")
_COMMAND_ACROSS = OBSERVATION_NAMES.index("command_across_cm")


def scripted_policy(env: gym.Env) -> Callable[[np.ndarray], np.ndarray]:
    """The scripted episode's controllers as a policy of ``env`` (it reads the env's plan).

    Example:
        >>> from envs import CutEnv
        >>> env = CutEnv(time_limit_s=0.1)
        >>> obs, info = env.reset(seed=0)
        >>> policy = scripted_policy(env)
        >>> obs, reward, terminated, truncated, info = env.step(policy(obs))
        >>> info["clipped_actions"]
        0
    """
    inner: MuscleSeparationEnv = env.unwrapped
    return lambda _obs: inner.scripted_action()


@dataclass(frozen=True)
class TableSkimmingKnife:
    """A hand-written feedback policy of ``Cut``'s observation: the knife at full speed
    along its path, its tip ``height_m`` above the table (the lowest bindings hold until the
    tip is within the aponeurosis' knife margin of it, and a blade pressed on the table trips
    the protective stop): the depth wanted below the path is the path's height over the table
    (the tip's height plus its depth below the path) less ``height_m``.

    Example:
        >>> obs = np.zeros(len(OBSERVATION_NAMES), np.float32)
        >>> obs[_TIP_HEIGHT] = 1.7  # cm above the table, on the path
        >>> TableSkimmingKnife()(obs)  # 15 mm down, of the depth's 30 mm bound
        array([1. , 0. , 0.5, 0. ], dtype=float32)
    """

    #: The envs whose observation and action this policy is written for.
    fits: ClassVar[tuple[str, ...]] = ("musclecell/Cut-v2", "musclecell/Cut-v1",
                                       "musclecell/Steer-v2", "musclecell/Steer-v1")
    height_m: float = 0.002
    limits: ActionLimits = field(default_factory=ActionLimits)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        path_height_m = float(obs[_TIP_HEIGHT] + obs[_TIP_DEPTH]) / 100.0
        depth = np.clip((path_height_m - self.height_m) / self.limits.knife_max_depth_m,
                        -1.0, 1.0)
        return np.array([1.0, 0.0, depth, 0.0], dtype=np.float32)


@dataclass(frozen=True)
class HoldThenPullAway:
    """A hand-written feedback policy of ``Pull``'s observation: the shank held where it
    was grasped while the knife cuts (its path progress below 1), since a pull ahead of the
    knife tears what the blade has not reached, then taken away by the action ``away`` (cubed
    times 0.2 m per axis: (0, 0.8, 0.8) is 10 cm across and 10 cm up).

    Example:
        >>> obs = np.zeros(len(OBSERVATION_NAMES), np.float32)
        >>> HoldThenPullAway()(obs)  # the knife has not come through
        array([0., 0., 0.], dtype=float32)
        >>> obs[_PROGRESS] = 1.0
        >>> HoldThenPullAway()(obs)
        array([0. , 0.8, 0.8], dtype=float32)
    """

    #: The envs whose observation and action this policy is written for.
    fits: ClassVar[tuple[str, ...]] = ("musclecell/Pull-v2", "musclecell/Pull-v1")
    away: tuple[float, float, float] = (0.0, 0.8, 0.8)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        if obs[_PROGRESS] < 0.999:  # within 0.1 % of the path's end counts as through
            return np.zeros(3, dtype=np.float32)
        return np.array(self.away, dtype=np.float32)


@dataclass(frozen=True)
class SteeringKnife:
    """The project's steering rule (:mod:`controllers.steering`) as a feedback policy of ``Steer``'s
    observation (its ``Cut-v2`` entries), on :class:`TableSkimmingKnife`'s knife: the load across
    the blade (the F/T sensor's y, times ``load_sign``), what lies beyond ``dead_band_n`` about
    ``on_interface_load_n`` integrated at ``gain_m_per_n_s`` into the across offset (a load towards
    the side that gives less counting ``weak_side_gain`` times), in the middle ``middle_fraction``
    of the cut only, within ``max_across_m``. The integral is the offset the knife is commanded now
    (the observation's ``command_across_cm``), so the policy holds no state of its own: a clone, a
    worker process or another env may call it on any observation. The depth is the table's: the tip
    held ``height_m`` above it, whatever the path's height error. The defaults are those
    :func:`cell.learning.headroom.tune_rule` chose (the docs' benchmarks page says on how many
    tuning episodes).

    Example:
        >>> obs = np.zeros(len(OBSERVATION_NAMES), np.float32)
        >>> obs[_PROGRESS], obs[_KNIFE_FY] = 0.5, 0.3  # mid-cut, 3 N across
        >>> bool(SteeringKnife()(obs)[1] < 0.0)  # steered away from the load
        True
    """

    fits: ClassVar[tuple[str, ...]] = ("musclecell/Steer-v2", "musclecell/Steer-v1")
    gain_m_per_n_s: float = 0.003
    on_interface_load_n: float = 0.0
    dead_band_n: float = 0.1
    weak_side_gain: float = 4.0
    load_sign: float = 1.0
    middle_fraction: float = 0.75
    max_across_m: float = 0.012
    height_m: float = 0.002
    dt_s: float = 0.02
    limits: ActionLimits = field(default_factory=lambda: ActionLimits(knife_max_across_m=0.012))

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        across_m = float(obs[_COMMAND_ACROSS]) / 100.0
        if abs(float(obs[_PROGRESS]) - 0.5) <= 0.5 * self.middle_fraction:
            load = self.load_sign * float(obs[_KNIFE_FY]) * 10.0  # the observation's 10 N
            beyond = load - self.on_interface_load_n
            beyond = np.sign(beyond) * max(abs(beyond) - self.dead_band_n, 0.0)
            if beyond < 0.0:
                beyond *= self.weak_side_gain
            across_m = float(np.clip(across_m - self.gain_m_per_n_s * beyond * self.dt_s,
                                     -self.max_across_m, self.max_across_m))
        action = TableSkimmingKnife(self.height_m, self.limits)(obs)
        action[1] = np.clip(across_m / self.limits.knife_max_across_m, -1.0, 1.0)
        return action


#: The hand-written feedback policies of the observation, by name: what a warm start of
#: ``musclecell learn`` clones and ``musclecell evaluate`` plays beside the learned policy
#: (each reads nothing but the observation, and its class attribute ``fits`` names the env
#: ids it is written for).
DEMONSTRATORS: dict[str, Callable[[], Callable[[np.ndarray], np.ndarray]]] = {
    "table-skimming-knife": TableSkimmingKnife,
    "hold-then-pull-away": HoldThenPullAway,
    "steering-knife": SteeringKnife,
}


def demonstrators_for(env_id: str) -> list[str]:
    """The names of the :data:`DEMONSTRATORS` that fit ``env_id`` (a deprecated id counts as
    the id that replaces it), in the dict's order.

    Example:
        >>> demonstrators_for("musclecell/Pull-v2")
        ['hold-then-pull-away']
        >>> demonstrators_for("musclecell/MuscleSeparation-v2")
        []
    """
    current = DEPRECATED_IDS.get(env_id, env_id)
    return [name for name, policy in DEMONSTRATORS.items() if current in policy.fits]


@dataclass(frozen=True)
class LinearPolicy:
    """``action = tanh(weights @ obs + bias)``.

    Example:
        >>> policy = LinearPolicy.from_vector(np.zeros(4 * 35), action_dims=4, obs_dims=34)
        >>> policy(np.ones(34))
        array([0., 0., 0., 0.], dtype=float32)
    """

    weights: np.ndarray
    bias: np.ndarray

    @classmethod
    def from_vector(cls, vector: np.ndarray, action_dims: int, obs_dims: int) -> LinearPolicy:
        """Unpack a flat parameter vector of ``action_dims * (obs_dims + 1)`` entries."""
        matrix = np.asarray(vector, float).reshape(action_dims, obs_dims + 1)
        return cls(matrix[:, :-1], matrix[:, -1])

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return np.tanh(self.weights @ obs + self.bias).astype(np.float32)


def episode_return(env: gym.Env, policy: Callable[[np.ndarray], np.ndarray], seed: int
                   ) -> tuple[float, dict]:
    """Run one episode; returns the undiscounted return and the last info."""
    obs, info = env.reset(seed=seed)
    total, done = 0.0, False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        total += float(reward)
        done = terminated or truncated
    return total, info


@dataclass(frozen=True)
class CrossEntropyParams:
    """Cross-entropy search: ``population`` samples per iteration from a diagonal Gaussian,
    refitted to the best ``elite``; it starts at zero with spread ``weight_std`` on the
    weights and ``bias_std`` on the biases (small weights keep the first policies from
    saturating on the observation's larger entries), and ``min_std`` is its floor.

    Example:
        >>> CrossEntropyParams(iterations=2).population
        8
    """

    iterations: int = 8
    population: int = 8
    elite: int = 2
    weight_std: float = 0.05
    bias_std: float = 0.5
    min_std: float = 0.02


def cross_entropy_search(env: gym.Env, params: CrossEntropyParams, seed: int,
                         report: Callable[[int, np.ndarray], None] | None = None
                         ) -> tuple[LinearPolicy, list[float]]:
    """Tune a :class:`LinearPolicy` on ``env``; every iteration evaluates its population on
    the same episode seed (common random numbers). Returns the final mean policy and the
    population's mean return per iteration.

    Example:
        >>> import gymnasium as gym
        >>> search = CrossEntropyParams(iterations=2, population=4)
        >>> policy, curve = cross_entropy_search(gym.make("Pendulum-v1"), search, seed=0)
        >>> policy.weights.shape, len(curve)
        ((1, 3), 2)
    """
    rng = np.random.default_rng(seed)
    obs_dims = env.observation_space.shape[0]
    action_dims = env.action_space.shape[0]
    mean = np.zeros(action_dims * (obs_dims + 1))
    std = np.full((action_dims, obs_dims + 1), params.weight_std)
    std[:, -1] = params.bias_std
    std = std.ravel()
    curve = []
    for iteration in range(params.iterations):
        samples = mean + std * rng.standard_normal((params.population, len(mean)))
        returns = np.array([
            episode_return(env, LinearPolicy.from_vector(s, action_dims, obs_dims),
                           seed + iteration)[0] for s in samples])
        elite = samples[np.argsort(returns)[-params.elite:]]
        mean = elite.mean(axis=0)
        std = np.maximum(elite.std(axis=0), params.min_std)
        curve.append(float(returns.mean()))
        if report is not None:
            report(iteration, returns)
    return LinearPolicy.from_vector(mean, action_dims, obs_dims), curve


def true_interface_policy(env: gym.Env, height_m: float = 0.002
                          ) -> Callable[[np.ndarray], np.ndarray]:
    """The ceiling of ``Steer``: :class:`TableSkimmingKnife`'s knife with the across
    offset that puts the tip on the true interface (a privileged baseline: it reads the
    env's truth, :meth:`envs.steer.SteerEnv.across_to_interface_m`).

    Example:
        >>> import envs
        >>> env = envs.SteerEnv(time_limit_s=0.1)
        >>> obs, info = env.reset(seed=0)
        >>> true_interface_policy(env)(obs).shape
        (4,)
    """
    inner = env.unwrapped
    skimming = TableSkimmingKnife(height_m, inner.limits)

    def act(obs: np.ndarray) -> np.ndarray:
        action = skimming(obs)
        action[1] = np.clip(inner.across_to_interface_m() / inner.limits.knife_max_across_m,
                            -1.0, 1.0)
        return action

    return act
