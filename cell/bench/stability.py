"""The largest time step a run survives: bracketing and bisection, with MuJoCo's warnings
kept quiet while it diverges on purpose."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import mujoco

from cell.errors import DivergenceError
from cell.sim.simulation import TissueSimulation


def largest_stable_timestep_s(survives: Callable[[float], bool], guess_s: float, cap_s: float,
                              tolerance: float) -> tuple[float, bool]:
    """Largest step (s) for which ``survives`` holds, to a relative ``tolerance``, and whether
    it is the cap ``cap_s``.

    Brackets from ``guess_s`` by factors of 1.25, then bisects in log scale. Assumes one
    threshold: every step below a surviving one survives.

    Example:
        >>> largest_stable_timestep_s(lambda h: h < 3e-3, 1e-3, 1e-2, 0.01)[0] < 3e-3
        True
    """
    if survives(cap_s):
        return cap_s, True
    grow = 1.25
    x = min(guess_s, cap_s / grow)
    if survives(x):
        low, high = x, cap_s
        while x * grow < high:
            x *= grow
            if not survives(x):
                high = x
                break
            low = x
    else:
        high = x
        while not survives(x := x / grow):
            high = x
            if x < 1e-7:
                raise DivergenceError(0.0, f"unstable at every step down to {x:.3g} s")
        low = x
    while high / low > 1.0 + tolerance:
        middle = math.sqrt(low * high)
        low, high = (middle, high) if survives(middle) else (low, middle)
    return low, False


def survives(sim: TissueSimulation, timestep_s: float, steps: int) -> bool:
    """Whether ``steps`` steps of ``timestep_s`` from rest pass the simulation's divergence
    check after each step (no NaN, no fatal MuJoCo warning, no tissue faster than the
    scenario's limit).

    Example:
        >>> from cell.bench.tissue_variants import bench_scenario, tissue_run
        >>> from cell.tissue.material import default_meat
        >>> survives(tissue_run(bench_scenario(default_meat(), 0.05)), 0.002, 5)
        True
    """
    sim.model.opt.timestep = timestep_s
    sim.reset()
    try:
        for _ in range(steps):
            sim.step()
    except DivergenceError:
        return False
    return True


@contextmanager
def quiet_mujoco() -> Iterator[None]:
    """MuJoCo's warnings dropped: the stable step search diverges on purpose, and the default
    handler would print each and append it to MUJOCO_LOG.TXT. The handler that was set
    before comes back after.

    Example:
        >>> with quiet_mujoco():
        ...     pass
    """
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda message: None)
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(previous)
