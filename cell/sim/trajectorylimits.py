"""The limits report of an episode's robot program
(:class:`~cell.sim.trajectory.EpisodeTrajectory`): per arm, the largest joint speed and
acceleration, planned and executed, against the arm's rated limits, and the smallest clearance
of the arm (its links and its tool) to each other arm, the table and the fixture over the
executed trajectory.

Clearances are MuJoCo's signed geom distances (``mj_geomDistance``, m; negative: the shapes
overlap) over the executed joint positions of every control step, the arms posed by forward
kinematics; geom pairs whose bounding spheres are farther apart than the smallest distance
found so far are skipped.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from cell.sim.trajectory import ArmTrajectory, EpisodeTrajectory

#: Each arm's tool, whose geoms count as the arm's.
ARM_TOOLS = {"knife_arm": "knife", "pull_arm": "gripper", "camera_arm": "camera"}
#: The cell's fixed obstacles: their names in the report, and the body (or geom) they are.
OBSTACLES = {"table": ("geom", "table"), "fixture": ("body", "fixture")}
#: Farther than anything in the cell, m: where the search for the closest pair starts.
_FAR_M = 10.0
#: How close to the smallest the clearances reported are, m.
CLEARANCE_TOLERANCE_M = 1e-4
_FROMTO = np.zeros(6)


@dataclass(frozen=True)
class LimitSettings:
    """What the report flags.

    Attributes:
        min_clearance_m: a clearance below this is flagged, m (0: only contact).

    Example:
        >>> LimitSettings().min_clearance_m
        0.0
    """

    min_clearance_m: float = 0.0


def _arm_geoms(model: mujoco.MjModel, prefixes: tuple[str, ...]) -> np.ndarray:
    return np.array([g for g in range(model.ngeom)
                     if model.body(int(model.geom_bodyid[g])).name.split("/")[0] in prefixes])


def _obstacle_geoms(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    out = {}
    for name, (kind, target) in OBSTACLES.items():
        if kind == "geom":
            out[name] = np.array([model.geom(target).id])
        else:
            body = model.body(target).id
            out[name] = np.flatnonzero(model.geom_bodyid == body)
    return out


def clearances(model: mujoco.MjModel, qpos: np.ndarray, trajectory: EpisodeTrajectory,
               tolerance_m: float = CLEARANCE_TOLERANCE_M,
               arms_model: mujoco.MjModel | None = None
               ) -> dict[str, dict[str, dict[str, Any]]]:
    """Per arm and obstacle (the other arms, ``table``, ``fixture``): the smallest signed
    distance over the executed trajectory, m (to ``tolerance_m``), when it happened and
    between which geoms. ``qpos``: the scene's positions the arms are posed over (the other
    bodies stay there); ``arms_model``: the arms and tools alone, with the scene's names and
    kinematics (the IK's model), to pose them faster."""
    arms = list(trajectory.arms)
    groups = {arm: _arm_geoms(model, (arm, ARM_TOOLS[arm])) for arm in arms}
    groups.update(_obstacle_geoms(model))
    poses = _GeomPoses(model, qpos, trajectory, np.concatenate(list(groups.values())),
                       arms_model)
    best: dict[str, dict[str, dict[str, Any]]] = {arm: {} for arm in arms}
    for n, arm in enumerate(arms):
        for name in [*arms[n + 1:], *OBSTACLES]:
            entry = poses.closest(groups[arm], groups[name], tolerance_m)
            best[arm][name] = entry
            if name in best:
                best[name][arm] = {**entry, "geoms": entry["geoms"][::-1]}
    return {arm: {name: best[arm][name] for name in [*arms, *OBSTACLES] if name in best[arm]}
            for arm in arms}


class _GeomPoses:
    """The poses of some geoms at every control step of the executed trajectory (forward
    kinematics), and how far each may have moved since the first: what bounds a pair's
    distance between the steps where it is measured."""

    def __init__(self, model: mujoco.MjModel, qpos: np.ndarray, trajectory: EpisodeTrajectory,
                 geoms: np.ndarray, arms_model: mujoco.MjModel | None) -> None:
        self.model, self.time_s = model, trajectory.time_s
        self.data = mujoco.MjData(model)
        self.data.qpos[:] = qpos
        mujoco.mj_kinematics(model, self.data)
        self.column = {int(g): k for k, g in enumerate(geoms)}
        self.xpos = np.repeat(self.data.geom_xpos[geoms][None], trajectory.steps, axis=0)
        self.xmat = np.repeat(self.data.geom_xmat[geoms][None], trajectory.steps, axis=0)
        # The moving geoms posed by the arms' own model where there is one (the same
        # kinematics, without the meat's bodies: faster), else by the scene's.
        kinematics = model if arms_model is None else arms_model
        data = self.data if arms_model is None else mujoco.MjData(arms_model)
        moving = [k for k, g in enumerate(geoms) if model.body_weldid[model.geom_bodyid[g]]]
        ids = [kinematics.geom(model.geom(int(geoms[k])).name).id for k in moving]
        qadr = [np.array([kinematics.joint(j).qposadr[0] for j in arm.joints])
                for arm in trajectory.arms.values()]
        for k in range(trajectory.steps):
            for adr, arm in zip(qadr, trajectory.arms.values(), strict=True):
                data.qpos[adr] = arm.executed_q_rad[k]
            mujoco.mj_kinematics(kinematics, data)
            self.xpos[k, moving], self.xmat[k, moving] = data.geom_xpos[ids], data.geom_xmat[ids]
        # A point of a geom moves at most its centre's step plus its bounding radius times
        # the rotation's step (Frobenius norm): summed from the first step on.
        step = (np.linalg.norm(np.diff(self.xpos, axis=0), axis=2)
                + model.geom_rbound[geoms] * np.linalg.norm(np.diff(self.xmat, axis=0), axis=2))
        self.travel = np.vstack([np.zeros(len(geoms)), np.cumsum(step, axis=0)])

    def distance(self, k: int, a: int, b: int, limit_m: float) -> float:
        """The signed distance of geoms ``a`` and ``b`` at step ``k`` (``limit_m`` if
        farther)."""
        for g in (a, b):
            self.data.geom_xpos[g] = self.xpos[k, self.column[g]]
            self.data.geom_xmat[g] = self.xmat[k, self.column[g]]
        return mujoco.mj_geomDistance(self.model, self.data, a, b, limit_m, _FROMTO)

    def closest(self, geoms_a: np.ndarray, geoms_b: np.ndarray, tolerance_m: float
                ) -> dict[str, Any]:
        """The smallest distance between two groups of geoms over the steps, to
        ``tolerance_m``: each pair measured at a step, then again only once the two may have
        moved together by more than its distance's margin over the smallest found."""
        model = self.model
        entry: dict[str, Any] = {"clearance_m": np.inf, "time_s": None, "geoms": None}
        ca = [self.column[int(g)] for g in geoms_a]
        cb = [self.column[int(g)] for g in geoms_b]
        # Each pair's bounding spheres' smallest gap over the steps: the closest pairs first.
        spheres = (np.linalg.norm(self.xpos[:, ca, None] - self.xpos[:, None, cb], axis=3)
                   - model.geom_rbound[geoms_a][:, None] - model.geom_rbound[geoms_b][None]
                   ).min(axis=0)
        for flat in np.argsort(spheres, axis=None, kind="stable"):
            i, j = np.unravel_index(flat, spheres.shape)
            if spheres[i, j] >= entry["clearance_m"]:
                break
            a, b = int(geoms_a[i]), int(geoms_b[j])
            travel = self.travel[:, ca[i]] + self.travel[:, cb[j]]
            k = 0
            while k < len(travel):
                d = self.distance(k, a, b, _FAR_M)
                if d < entry["clearance_m"]:
                    entry.update(clearance_m=float(d), time_s=float(self.time_s[k]),
                                 geoms=[model.geom(a).name, model.geom(b).name])
                margin = d - entry["clearance_m"] + tolerance_m
                k = max(k + 1, int(np.searchsorted(travel, travel[k] + margin, side="left")))
        return entry


def _joint_extremes(arm: ArmTrajectory, dt_s: float) -> dict[str, Any]:
    planned_qd = np.abs(arm.planned_qd_rad_s).max(axis=0)
    executed_qd = np.abs(arm.executed_qd_rad_s).max(axis=0)
    planned_qdd = np.abs(np.diff(arm.planned_qd_rad_s, axis=0) / dt_s).max(axis=0)
    executed_qdd = np.abs(np.diff(arm.executed_qd_rad_s, axis=0) / dt_s).max(axis=0)
    rated = arm.max_accel_rad_s2
    return {joint: {"max_speed_rad_s": float(arm.max_speed_rad_s[k]),
                    "planned_speed_rad_s": float(planned_qd[k]),
                    "executed_speed_rad_s": float(executed_qd[k]),
                    "max_acceleration_rad_s2": None if rated is None else float(rated[k]),
                    "planned_acceleration_rad_s2": float(planned_qdd[k]),
                    "executed_acceleration_rad_s2": float(executed_qdd[k])}
            for k, joint in enumerate(arm.joints)}


def limits_report(model: mujoco.MjModel, qpos: np.ndarray, trajectory: EpisodeTrajectory,
                  settings: LimitSettings = LimitSettings(),
                  arms_model: mujoco.MjModel | None = None) -> dict[str, Any]:
    """The report (JSON-ready): per arm its joints' extremes and its clearances, and
    ``flags``, one line per limit broken (empty: the program holds). Accelerations are
    flagged against an arm's rated ones where its scenario gives them (``max_accel_rad_s2``;
    the built-in arms rate speeds only). ``qpos`` and ``arms_model``: as :func:`clearances`."""
    clear = clearances(model, qpos, trajectory, arms_model=arms_model)
    arms, flags = {}, []
    for prefix, arm in trajectory.arms.items():
        joints = _joint_extremes(arm, trajectory.control_dt_s)
        for joint, figures in joints.items():
            for kind, (quantity, unit, key) in itertools.product(
                    ("planned", "executed"), (("speed", "rad/s", "speed_rad_s"),
                                              ("acceleration", "rad/s2", "acceleration_rad_s2"))):
                value, limit = figures[f"{kind}_{key}"], figures[f"max_{key}"]
                if limit is not None and value > limit:
                    flags.append(f"{joint}: {kind} {quantity} {value:.3g} {unit} over its "
                                 f"limit {limit:.3g} {unit}")
        for name, entry in clear[prefix].items():
            if entry["clearance_m"] < settings.min_clearance_m:
                flags.append(f"{prefix}: clearance to {name} {entry['clearance_m']:.4g} m "
                             f"under {settings.min_clearance_m:.4g} m at {entry['time_s']:.3f} s"
                             f" ({' / '.join(entry['geoms'])})")
        arms[prefix] = {"joints": joints, "clearance": clear[prefix]}
    return {"control_rate_hz": 1.0 / trajectory.control_dt_s, "steps": trajectory.steps,
            "min_clearance_m": settings.min_clearance_m, "arms": arms, "flags": flags,
            "holds": not flags}
