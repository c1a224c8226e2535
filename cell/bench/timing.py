"""Timing steps on a shared machine: the best of interleaved repetitions, by wall and CPU
time."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class StepTime:
    """Time of one step, s: ``wall_s`` by ``time.perf_counter`` (the figure reported), and
    ``cpu_s``, this process's CPU time, which other processes on the machine do not inflate:
    where the two differ, the machine was busy."""

    wall_s: float
    cpu_s: float


@dataclass(frozen=True)
class TimingJob:
    """One thing to time: ``step(n)`` runs n steps from the state that ``reset()`` restores;
    a repetition runs ``steps`` of them."""

    step: Callable[[int], None]
    reset: Callable[[], None]
    steps: int


def best_step_times(jobs: Sequence[TimingJob], repetitions: int) -> list[StepTime]:
    """Best over ``repetitions`` of each job's time per step.

    The repetitions interleave (the first of every job, then the second, ...): on a shared
    machine slow and fast spells last seconds, longer than a repetition, and interleaving
    spreads each job's repetitions over them all and gives every job the same conditions.
    The fastest repetition is the one the machine disturbed least.

    Example:
        >>> job = TimingJob(lambda n: None, lambda: None, 10)
        >>> best_step_times([job, job], 3)[1].wall_s < 1e-3
        True
    """
    wall = [math.inf] * len(jobs)
    cpu = [math.inf] * len(jobs)
    for _ in range(repetitions):
        for k, job in enumerate(jobs):
            job.reset()
            start, start_cpu = time.perf_counter(), time.process_time()
            job.step(job.steps)
            wall[k] = min(wall[k], time.perf_counter() - start)
            cpu[k] = min(cpu[k], time.process_time() - start_cpu)
    return [StepTime(w / job.steps, c / job.steps) for w, c, job in zip(wall, cpu, jobs,
                                                                          strict=True)]

