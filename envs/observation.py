"""What the policy sees: the knife against its path, the tools' forces, the bindings' state.

The observation is a float32 vector, every entry scaled to order one and clipped to
``[-OBSERVATION_BOUND, OBSERVATION_BOUND]`` (non-finite readings become 0), in the order of
:data:`OBSERVATION_NAMES`; lengths are in cm, forces in 10 N, torques in N m, strains in units
of the tearing stretch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell.robots.names import GRASP_SITE, KNIFE_BLADE_GEOM, KNIFE_TIP
from cell.sim.episode import Episode
from envs.commands import KnifeCommand, PullCommand

#: Every entry of the observation is clipped to plus or minus this.
OBSERVATION_BOUND = 100.0
#: The guideline points ahead of the knife that the policy sees, m along the path.
LOOKAHEAD_M = (0.01, 0.02, 0.04)
#: Bindings this far ahead of the tip along the path count as "just ahead" of it, and this
#: far on either side as "near the cut", m.
NEAR_M = 0.05

_CM = 100.0
_FORCE_SCALE_N = 10.0
_PULL_SCALE_M = 0.1

#: The observation's entries by name, in order (units in the names, see the module docstring;
#: the table with their meaning: :class:`envs.separation.MuscleSeparationEnv`).
OBSERVATION_NAMES = (
    "tip_along_cm", "tip_across_cm", "tip_depth_cm", "tip_height_cm", "blade_yaw_rad",
    "path_progress",
    "command_across_cm", "command_depth_cm", "command_yaw_rad",
    *(f"path_{d * 100:.0f}cm_{axis}_cm" for d in LOOKAHEAD_M
      for axis in ("along", "across", "depth")),
    "knife_fx", "knife_fy", "knife_fz", "knife_tx", "knife_ty", "knife_tz",
    "grasp_dx", "grasp_dy", "grasp_dz", "pull_fx", "pull_fy", "pull_fz",
    "released_fraction", "released_ahead_fraction", "strain_near_cut", "strain_max",
    "time_fraction",
)


@dataclass(frozen=True)
class Reading:
    """The cell after a control step (SI units, world frame unless said).

    Attributes:
        tip_m: the knife tip's position.
        tip_height_m: the tip's height above the table's top (a cell knows its table: the
            one absolute the knife may not cross).
        blade_rotation: the blade's rotation (x along the edge, z down its axis).
        knife_force_n, knife_torque_nm: the tared, noisy F/T sensor (sensor frame).
        grasp_m: the grasp site's position.
        pull_force_n: the gripper's tared, noisy force sensor (sensor frame).
        released_fraction: bindings released of all.
        released_ahead: of the bindings up to ``NEAR_M`` ahead of the tip along the path,
            those released (1 when there are none).
        strain_near: mean stretch beyond rest of the bound bindings within ``NEAR_M`` of the
            tip along the path, in tearing stretches (0 when none).
        strain_max: the largest such stretch over all bound bindings.
        blade_contacts: contacts between the blade and the muscles.
        under_blade: bindings under the blade.
        interface_offset_m: the tip's distance across from the true interface.

    Example:
        >>> zero = np.zeros(3)
        >>> reading = Reading(zero, 0.01, np.eye(3), zero, zero, zero, zero, released_fraction=0.5,
        ...                   released_ahead=0.0, strain_near=0.0, strain_max=0.0,
        ...                   blade_contacts=0, under_blade=0, interface_offset_m=0.0)
        >>> reading.released_fraction
        0.5
    """

    tip_m: np.ndarray
    tip_height_m: float
    blade_rotation: np.ndarray
    knife_force_n: np.ndarray
    knife_torque_nm: np.ndarray
    grasp_m: np.ndarray
    pull_force_n: np.ndarray
    released_fraction: float
    released_ahead: float
    strain_near: float
    strain_max: float
    blade_contacts: int
    under_blade: int
    interface_offset_m: float

    @property
    def knife_force_magnitude_n(self) -> float:
        """The knife sensor's force magnitude, N."""
        return float(np.linalg.norm(self.knife_force_n))

    @property
    def pull_force_magnitude_n(self) -> float:
        """The gripper sensor's force magnitude, N."""
        return float(np.linalg.norm(self.pull_force_n))

    @property
    def blade_in_flesh(self) -> bool:
        """The blade touches muscle with no binding under it: it cuts flesh, not the
        aponeurosis."""
        return self.blade_contacts > 0 and self.under_blade == 0


class Sensing:
    """Reads :class:`Reading` from an episode's simulation.

    Example:
        >>> from cell.sim.episode import Episode
        >>> from cell.sim.scenario import Scenario
        >>> from cell.tissue.shape import MuscleShape
        >>> episode = Episode(Scenario(tissue=MuscleShape(cell_size_m=0.05)))
        >>> from envs.commands import KnifeCommand
        >>> from envs.params import ActionLimits
        >>> plan = episode.plan()
        >>> knife = KnifeCommand(plan.knife, plan.cut_window_s, 0.03, ActionLimits())
        >>> reading = Sensing(episode).read(knife)
        >>> reading.released_fraction, reading.blade_contacts  # before the cut
        (0.0, 0)
    """

    def __init__(self, episode: Episode) -> None:
        self.episode = episode
        model = episode.sim.model
        self._tip = model.site(KNIFE_TIP).id
        self._grasp = model.site(GRASP_SITE).id
        self._blade = model.geom(KNIFE_BLADE_GEOM).id
        self._table_z_m = episode.scenario.layout.table_height_m

    def read(self, knife: KnifeCommand) -> Reading:
        """The cell now; ``knife`` gives the path the tip is measured along."""
        episode = self.episode
        sim, data, scene = episode.sim, episode.sim.data, episode.scene
        apo, params = scene.aponeurosis, episode.scenario.aponeurosis
        tip = data.site_xpos[self._tip].copy()
        tangent = knife.path_pose()[1][:, 0]
        round_end, shank_end = apo.endpoints(data)
        along = (0.5 * (round_end + shank_end) - tip) @ tangent
        bound = apo.bound
        ahead = (along >= 0.0) & (along <= NEAR_M)
        near = np.abs(along) <= NEAR_M
        strain = (apo.lengths(data) - apo.rest_length_m) / params.tearing_stretch_m
        blade_pos, blade_mat = data.geom_xpos[self._blade], data.geom_xmat[self._blade]
        under = apo.under_blade(data, blade_pos, blade_mat, sim.model.geom_size[self._blade],
                                params.knife_margin_m)
        contact = data.contact
        touching = (contact.geom == self._blade).any(axis=1) & (contact.flex >= 0).any(axis=1)
        interface_y = float(scene.mesh.interface_y(tip[:1], tip[2:])[0])
        return Reading(
            tip_m=tip,
            tip_height_m=float(tip[2]) - self._table_z_m,
            blade_rotation=blade_mat.reshape(3, 3).copy(),
            knife_force_n=sim.read("knife/force"),
            knife_torque_nm=sim.read("knife/torque"),
            grasp_m=data.site_xpos[self._grasp].copy(),
            pull_force_n=sim.read("gripper/force"),
            released_fraction=float(1.0 - bound.mean()),
            released_ahead=float(1.0 - bound[ahead].mean()) if ahead.any() else 1.0,
            strain_near=float(strain[near & bound].mean()) if (near & bound).any() else 0.0,
            strain_max=float(strain[bound].max(initial=0.0)),
            blade_contacts=int(touching.sum()),
            under_blade=int(under.sum()),
            interface_offset_m=abs(float(tip[1]) - interface_y),
        )


def observe(reading: Reading, knife: KnifeCommand, pull: PullCommand,
            time_fraction: float) -> np.ndarray:
    """The observation vector (see :data:`OBSERVATION_NAMES`)."""
    path_m, frame = knife.path_pose()
    tip = (reading.tip_m - path_m) @ frame * _CM
    edge = reading.blade_rotation[:, 0]
    yaw = np.arctan2(edge @ frame[:, 1], edge @ frame[:, 0])
    ahead = [(knife.path_pose(knife.tau_s + d / knife.speed_m_s)[0] - reading.tip_m) @ frame
             * _CM for d in LOOKAHEAD_M]
    command = knife.offsets() * np.array([_CM, _CM, 1.0])
    values = np.concatenate([
        tip, [reading.tip_height_m * _CM, yaw, knife.progress], command, *ahead,
        reading.knife_force_n / _FORCE_SCALE_N, reading.knife_torque_nm,
        (reading.grasp_m - pull.origin_m) / _PULL_SCALE_M, reading.pull_force_n / _FORCE_SCALE_N,
        [reading.released_fraction, reading.released_ahead, reading.strain_near,
         reading.strain_max, time_fraction],
    ])
    values = np.nan_to_num(values, nan=0.0, posinf=OBSERVATION_BOUND, neginf=-OBSERVATION_BOUND)
    return np.clip(values, -OBSERVATION_BOUND, OBSERVATION_BOUND).astype(np.float32)
