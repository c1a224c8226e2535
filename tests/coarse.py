"""The default cell made quick for tests: a coarse tissue and a brisk plan, so that an episode
takes seconds."""

from __future__ import annotations

from dataclasses import replace

from cell.sim.scenario import Scenario
from cell.tissue.geometry import MuscleShape
from controllers.gripper import PullPlan
from controllers.knife import CutPlan


def coarse(**changes: object) -> Scenario:
    """The default scenario with 5 cm tissue cells, a 6 cm/s cut and a 4 cm/s pull, then
    ``changes`` (scenario fields by name)."""
    base = Scenario(tissue=MuscleShape(cell_size_m=0.05), cut=CutPlan(speed_m_s=0.06),
                    pull=PullPlan(speed_m_s=0.04))
    return replace(base, **changes)
