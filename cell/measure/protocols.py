"""The protocol of a synthetic test (:class:`TestPlan`): the displacement path the machine
drives, as nominal strain at knots and linear between them, and the sample times; the three
shapes a protocol is made of (:func:`ramp`, :func:`relaxation`, :func:`cyclic`), and the force a
truth model gives along a plan (:func:`true_force_n`).

:mod:`cell.synthetic.specimen` draws the noise and writes the set.

Example:
    >>> plan = cyclic("y00", 0.0, 0.1, 0.01, cycles=2, samples=5)
    >>> plan.strain().round(3).tolist()
    [0.0, 0.1, 0.0, 0.1, 0.0]
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

StressLaw = Callable[[np.ndarray, np.ndarray, float], np.ndarray]
"""A truth model: nominal stress, Pa, from (time_s, strain, angle_deg) at one test's samples."""


@dataclass(frozen=True, eq=False)
class TestPlan:
    """One test of a protocol: the displacement path (strain at knots, linear between them,
    held after the last) and the sample times.

    Attributes:
        test_id, mode, angle_deg: as written in ``tests.csv`` (angle to the fibres, degrees).
        knots_s: (k,) times of the path's knots, s, increasing.
        knots_strain: (k,) nominal strain at the knots.
        time_s: (n,) sample times, s.
        description: one line saying what the test is (for a set's header).

    Example:
        >>> plan = ramp("t00", "tension", 0.0, 0.1, 0.01, samples=3)
        >>> plan.time_s.tolist(), plan.strain().tolist(), plan.description
        ([0.0, 5.0, 10.0], [0.0, 0.05, 0.1], 'tension to +0.10 at 1 %/s')
    """

    __test__ = False  # not a pytest test class, despite its name

    test_id: str
    mode: str
    angle_deg: float
    knots_s: tuple[float, ...]
    knots_strain: tuple[float, ...]
    time_s: np.ndarray
    description: str = ""

    def strain(self) -> np.ndarray:
        """The noise-free nominal strain at the sample times."""
        return np.interp(self.time_s, self.knots_s, self.knots_strain)


def ramp(test_id: str, mode: str, angle_deg: float, strain: float, rate_per_s: float,
         samples: int) -> TestPlan:
    """A ramp from 0 to ``strain`` at constant ``rate_per_s`` (1/s), evenly sampled."""
    end = abs(strain) / rate_per_s
    return TestPlan(test_id, mode, angle_deg, (0.0, end), (0.0, strain),
                    np.linspace(0.0, end, samples),
                    f"{mode} to {strain:+.2f} at {rate_per_s * 100:g} %/s")


def relaxation(test_id: str, angle_deg: float, strain: float, rate_per_s: float,
               hold_s: float, ramp_samples: int, hold_samples: int) -> TestPlan:
    """A ramp to ``strain``, then a hold sampled on a logarithmic clock (0.2 s to ``hold_s``)."""
    end = abs(strain) / rate_per_s
    time = np.concatenate([np.linspace(0.0, end, ramp_samples),
                           end + np.geomspace(0.2, hold_s, hold_samples)])
    return TestPlan(test_id, "relaxation", angle_deg, (0.0, end, end + hold_s),
                    (0.0, strain, strain), time,
                    f"ramp to {strain:+.2f} at {rate_per_s * 100:g} %/s, "
                    f"then a {hold_s:.0f} s hold")


def cyclic(test_id: str, angle_deg: float, amplitude: float, rate_per_s: float, cycles: int,
           samples: int) -> TestPlan:
    """Triangle cycles 0 -> ``amplitude`` -> 0 at constant ``rate_per_s``, evenly sampled."""
    half = abs(amplitude) / rate_per_s
    knots = tuple(half * k for k in range(2 * cycles + 1))
    strains = tuple(amplitude * (k % 2) for k in range(2 * cycles + 1))
    return TestPlan(test_id, "cyclic", angle_deg, knots, strains,
                    np.linspace(0.0, knots[-1], samples),
                    f"{cycles} cycles 0 to {amplitude:+.2f} and back at {rate_per_s * 100:g} %/s")


def true_force_n(plan: TestPlan, stress_pa: StressLaw, area_m2: float,
                 substeps: int = 1) -> np.ndarray:
    """The truth's force at the plan's sample times, N.

    With ``substeps`` > 1 the truth runs on a grid that many times finer than the samples
    (the displacement linear between them, as a reader of ``tests.csv`` reconstructs it) and
    is read back at the samples: a history-dependent truth then sees the path, not its samples.
    """
    if substeps == 1:
        return area_m2 * stress_pa(plan.time_s, plan.strain(), plan.angle_deg)
    fine = np.unique(np.linspace(plan.time_s[:-1], plan.time_s[1:], substeps + 1))
    strain = np.interp(fine, plan.time_s, plan.strain())
    return np.interp(plan.time_s, fine, stress_pa(fine, strain, plan.angle_deg)) * area_m2


def lab_protocol(rng: np.random.Generator) -> list[TestPlan]:
    """Ten tests as many labs run them: slow tension ramps (0.1 to 0.5 %/s) at three angles,
    relaxation holds in tension at three strains and two angles, load/unload cycles in
    tension and in compression at two angles; no compression ramp and no fast ramp, unlike
    the hidden-effect sets' own protocol."""
    rate = rng.uniform(0.001, 0.005)
    tension = rng.uniform(0.10, 0.18)
    mid = float(np.round(rng.uniform(30.0, 60.0)))
    held, hold_s = rng.uniform(0.05, 0.08), float(np.round(rng.uniform(120.0, 300.0)))

    def samples() -> int:
        return int(rng.integers(120, 240))

    return [ramp("t00", "tension", 0.0, tension, rate, samples()),
            ramp(f"t{mid:02.0f}", "tension", mid, tension, rate, samples()),
            ramp("t90", "tension", 90.0, tension, rate, samples()),
            relaxation("r00", 0.0, held, 5.0 * rate, hold_s, 30, samples()),
            relaxation("r00-high", 0.0, 2.0 * held, 5.0 * rate, hold_s, 30, samples()),
            relaxation("r90", 90.0, 1.5 * held, 5.0 * rate, hold_s, 30, samples()),
            cyclic("y00", 0.0, rng.uniform(0.10, 0.13), rate, 3, samples()),
            cyclic("y90", 90.0, rng.uniform(0.10, 0.13), rate, 3, samples()),
            cyclic("y00c", 0.0, rng.uniform(-0.15, -0.10), rate, 3, samples()),
            cyclic("y90c", 90.0, rng.uniform(-0.15, -0.10), rate, 3, samples())]
