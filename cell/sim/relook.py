"""Looking again between the passes of the cut: the camera sees the opening, the interface
estimate learns from it and the knife's next pass follows the update.

After pass k the knife waits out of the cut (:class:`~controllers.knife.PassPlan`'s
``looks_s``); the camera looks (:func:`~cell.perception.look.look`, the walk starting
where the first look's did), and the new guideline, the bottom of the opened valley, joins
the interface estimate (:meth:`~cell.perception.interface.SeenInterface.seen`). From then on
the knife's target moves along y by what the update changed at its place: the pass plan keeps
its timing, the blade its path along x and z.

Example:
    >>> from cell.perception.interface import SeenInterface
    >>> top = np.array([[-0.2, 0.0, 0.66], [0.2, 0.0, 0.66]])
    >>> def prior(x_m, z_m):
    ...     return 0.1 * (np.asarray(z_m) - 0.66) + 0.0 * np.asarray(x_m)
    >>> looks = Relooks(SeenInterface((top,), prior), top[0], looks_s=(5.0,), seed=0)
    >>> looks.due(4.9), looks.due(5.0)
    (False, True)
    >>> position_m, _ = looks.correct((np.array([0.0, 0.0, 0.61]), np.eye(3)))
    >>> float(position_m[1])  # no update yet: the plan's own target
    0.0
"""

from __future__ import annotations

import time
from typing import Any

import mujoco
import numpy as np

from cell.errors import PerceptionError
from cell.perception.interface import SeenInterface
from cell.perception.look import look
from cell.perception.params import PerceptionParams
from cell.polyline import closest_on, length
from cell.robots.camera import CameraRig

#: Which random stream of the seed the looks' camera noise draws from (the first look: 1).
_LOOK_STREAM = 2
#: Cloud points within this plan-view distance of a look's guideline show the opening, m.
_OPENING_HALF_WIDTH_M = 0.015
#: A look's guideline point joins the estimate where it lies within this of it along y, m,
#: plus _GATE_LEAN times its depth below the first look: the noise, and the most the lean
#: of the documented shapes (0 to 0.2) can differ from the generic model's 0.1.
_GATE_M = 0.0015
_GATE_LEAN = 0.12
#: A look whose guideline is shorter than this fraction of the first's, or keeps fewer of its
#: points than this fraction after the gate, is not used (the walk lost the valley).
_MIN_KEPT = 0.5


class Relooks:
    """The looks between passes and the interface estimate they update.

    Args:
        estimate: the interface as the first look gave it (the plan's).
        start_m: (3,) where the first look's walk started (the seen marker), m.
        looks_s: when the knife waits out of the cut between passes, s.
        seed: the scenario's seed (the looks' sensor noise follows it).

    Attributes:
        planned: the estimate the passes were planned with.
        estimate: the latest estimate.
        updates: what each look gave (JSON-ready, SI units).

    The module's example shows one.
    """

    def __init__(self, estimate: SeenInterface, start_m: np.ndarray, looks_s: tuple[float, ...],
                 seed: int) -> None:
        self.planned = self.estimate = estimate
        self.start_m = np.asarray(start_m, dtype=float)
        self.looks_s = looks_s
        self.seed = seed
        self.updates: list[dict[str, Any]] = []

    def due(self, time_s: float) -> bool:
        """Whether the next look is due at ``time_s``."""
        return len(self.updates) < len(self.looks_s) and time_s >= self.looks_s[len(self.updates)]

    def look(self, rig: CameraRig, data: mujoco.MjData, params: PerceptionParams,
             max_depth_m: float) -> tuple[np.ndarray, np.ndarray] | None:
        """Look at the meat now (``mj_forward`` run on ``data``) and update the estimate; the
        start point counts as seen within ``max_depth_m`` of its first depth (the opening
        lowers the surface there). Returns the new guideline (K, 3) and the seen opening
        (N, 3), m; None where the camera gave nothing (the update then says why and the
        estimate stays)."""
        index = len(self.updates) + 1
        rng = np.random.default_rng([self.seed, _LOOK_STREAM, index])
        clock = time.perf_counter()
        update: dict[str, Any] = {"look": index, "after_pass": index - 1,
                                  "time_s": float(data.time)}
        try:
            seen = look(rig, data, params, rng, self.start_m, max_depth_m)
        except PerceptionError as error:
            self.updates.append(update | {"error": str(error),
                                          "perception_s": time.perf_counter() - clock})
            return None
        guideline = seen.guideline.points_m
        kept = self._gate(guideline)
        update |= {"timings_s": dict(seen.timings_s), "guideline_samples": len(guideline),
                   "kept_fraction": float(kept.mean())}
        first_length = length(self.estimate.looks_m[0])
        if seen.guideline.length_m < _MIN_KEPT * first_length or kept.mean() < _MIN_KEPT:
            update["rejected"] = (f"the walk kept {seen.guideline.length_m:.3f} m of the "
                                  f"first look's {first_length:.3f} m, {kept.mean():.0%} of "
                                  "its points within the gate")
        else:
            self.estimate = self.estimate.seen(guideline[kept])
            lean = self.estimate.lean(guideline[kept, 0])
            update |= {"seen_below_first_m": self.estimate.deepest_m(),
                       "lean": {"min": float(lean.min()), "mean": float(lean.mean()),
                                "max": float(lean.max())}}
        self.updates.append(update | {"perception_s": time.perf_counter() - clock})
        near = closest_on(seen.cloud_m[:, :2], guideline[:, :2]).distance_m
        return guideline, seen.cloud_m[near <= _OPENING_HALF_WIDTH_M]

    def _gate(self, guideline_m: np.ndarray) -> np.ndarray:
        """(K,) which points of a look's guideline lie within the gate of the estimate."""
        x, y, z = guideline_m.T
        first = self.estimate.looks_m[0][np.argsort(self.estimate.looks_m[0][:, 0])]
        below = np.maximum(np.interp(x, first[:, 0], first[:, 2]) - z, 0.0)
        return np.abs(y - self.estimate(x, z)) <= _GATE_M + _GATE_LEAN * below

    def correct(self, target: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """The knife's planned target (position m, rotation) moved along y by what the looks
        changed in the estimate at its place."""
        position, rotation = target
        if self.estimate is self.planned:
            return position, rotation
        x, z = position[[0]], position[[2]]
        shift = float((self.estimate(x, z) - self.planned(x, z))[0])
        return position + np.array([0.0, shift, 0.0]), rotation

    def shift_m(self, path_m: np.ndarray) -> np.ndarray:
        """(N,) the y shift (m) the looks made at each point of ``path_m`` (N, 3)."""
        x, z = path_m[:, 0], path_m[:, 2]
        return self.estimate(x, z) - self.planned(x, z)
