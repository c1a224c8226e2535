"""The envs' own task settings, written here rather than taken from the library's defaults: the
cut and the pull they plan, the resolution they train at, and what each task asks.

A change of any value here changes the envs' behaviour: it needs a new env version (see
``tests/envs/test_versions.py``, which pins them).

Example:
    >>> scenario = task_scenario()
    >>> scenario.cut.table_clearance_m, scenario.pull.speed_m_s, scenario.tissue.cell_size_m
    (0.015, 0.04, 0.05)
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar

from cell.config import updated
from cell.errors import InputError
from cell.sim.scenario import Scenario
from cell.tissue.shape import MuscleShape
from controllers.gripper import PullPlan
from controllers.knife import CutPlan
from envs.params import ActionLimits, RewardParams, TaskParams

#: The envs' resolution of the tissue (m), to train and evaluate on; the scripted episode's
#: 0.025 m is finer and slower.
COARSE_CELL_SIZE_M = 0.05
#: The cut every env plans (the scripted knife's, and the path a policy's knife moves along):
#: 15 mm above the table, so that in ``Cut`` the policy must take the knife down to the
#: lowest bindings, which hold until the tip is within about 3 mm of the table.
ENV_CUT = CutPlan(enabled=True, speed_m_s=0.03, depth_m=None, table_clearance_m=0.015,
                  approach_height_m=0.06, lead_in_m=0.04, lead_out_m=0.04, cut_fraction=1.0,
                  start_s=0.4, passes=1, look_dwell_s=0.3)
#: The pull every env plans. Its pull-off, once the knife is out, holds no decision, so it runs
#: at 80 % of the pull action's top speed (``ActionLimits.pull_speed_m_s``).
ENV_PULL = PullPlan(enabled=True, tilt_deg=40.0, grasp_x_fraction=0.5, grasp_inset_m=0.035,
                    grasp_depth_m=0.03, grasp_radius_m=0.03, direction=(0.0, 1.0, 0.6),
                    tension_m=0.006, distance_m=0.16, speed_m_s=0.04, start_delay_s=1.0)
#: ``Cut``'s task: the knife must do the separating, so at most a quarter may tear (the
#: planned cut's clearance above the table leaves the lowest bindings to the pull's tearing);
#: the scripted pull takes the shank away, so the knife's task ends when the bindings are
#: released.
CUT_TASK = TaskParams(max_torn_fraction=0.25, clear_distance_m=0.0)
#: ``Pull``'s task: the scripted knife cuts down to the table, so what tears beyond its own
#: few is the pull's doing: at most a quarter, and the shank taken 5 cm away.
PULL_TASK = TaskParams(max_torn_fraction=0.25, clear_distance_m=0.05)
#: ``Pull``'s planned cut runs this far above the table (m), under the reset's options.
PULL_KNIFE_CLEARANCE_M = 0.002
#: Simulated time past the scripted plan's end the default time limit allows, s.
TIME_MARGIN_S = 2.0
#: Draws a reset makes before it gives up on a randomised world that fails to build or
#: diverges on the approach.
MAX_DRAWS = 5

Parameters = TypeVar("Parameters", ActionLimits, RewardParams, TaskParams)


def task_scenario(cell_size_m: float = COARSE_CELL_SIZE_M) -> Scenario:
    """The envs' default cell: the library's cell with the envs' own cut and pull
    (:data:`ENV_CUT`, :data:`ENV_PULL`) at ``cell_size_m``."""
    return Scenario(tissue=MuscleShape(cell_size_m=cell_size_m), cut=ENV_CUT, pull=ENV_PULL)


def parameters(kind: type[Parameters], value: Parameters | Mapping[str, Any] | None,
               name: str, base: Parameters | None = None) -> Parameters:
    """``value`` itself, ``base`` (the defaults of ``kind`` when None) for None, or ``base``
    with a mapping's fields.

    Example:
        >>> parameters(TaskParams, {"clear_distance_m": 0.1}, "task", CUT_TASK).max_torn_fraction
        0.25
    """
    base = kind() if base is None else base
    if value is None or isinstance(value, Mapping):
        return updated(base, value or {}, section=name)
    if not isinstance(value, kind):
        raise InputError(None, name, f"expected {kind.__name__} or a mapping, got {value!r}")
    return value
