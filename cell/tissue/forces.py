"""The forces on the two muscles that MuJoCo does not compute, written before every step.

One object serves the cell's :class:`~cell.sim.simulation.Simulation` and the tissue bench's
run on the muscles alone, so both step the same physics: the mass-spring springs (one
:class:`~cell.tissue.massspring.MassSpringModel` per muscle, so that each has its own fibre
field), then the aponeurosis' binding springs. With a continuum material MuJoCo's flex
elasticity acts instead and the tissue dofs' ``qfrc_applied`` entries are zeroed.
"""

from __future__ import annotations

import mujoco
import numpy as np

from cell.profiling import part
from cell.tissue.aponeurosis import Aponeurosis
from cell.tissue.massspring import MassSpringModel
from cell.tissue.material import ContinuumMaterial, MassSpringMaterial

#: The two muscles, flex names, in the order their forces are written.
MUSCLES = ("round", "shank")


def tissue_dofs(model: mujoco.MjModel, bodies: np.ndarray) -> np.ndarray:
    """The dofs of the tissue vertex bodies among ``bodies`` (pinned vertices have none),
    in body order.

    Example:
        >>> import mujoco, numpy as np
        >>> model = mujoco.MjModel.from_xml_string(
        ...     '<mujoco><worldbody><body><freejoint/><geom size="1"/></body></worldbody>'
        ...     '</mujoco>')
        >>> tissue_dofs(model, np.array([0, 1, 1])).tolist()
        [0, 1, 2, 3, 4, 5]
    """
    free = np.unique(bodies[model.body_dofnum[bodies] > 0])
    return np.concatenate([np.arange(model.body_dofadr[b], model.body_dofadr[b]
                                     + model.body_dofnum[b]) for b in free])


class TissueForces:
    """Mass-spring springs and binding springs on the two muscles (module docstring).

    :meth:`apply` owns the tissue dofs' entries of ``data.qfrc_applied``: it rewrites them
    from the state in ``data`` and returns the hooked bindings' pull on the blade (force N,
    moment N m about the blade centre) for the caller to put on the knife.

    With ``implicit``, the springs' and the bindings' forces go through the implicit step
    (:mod:`cell.tissue.implicit`) before MuJoCo's, the spring law run once every
    ``law_refresh_steps`` steps (:class:`MassSpringModel`).

    Attributes:
        springs: one :class:`MassSpringModel` per muscle (empty for a continuum material).
        implicit: whether the springs take the implicit step.
        aponeurosis: the bindings.
        dofs: the tissue vertices' dofs.

    Example:
        >>> from cell.sim.assembly import build_scene
        >>> from cell.sim.scenario import Scenario
        >>> from cell.tissue.geometry import MuscleShape
        >>> scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05))
        >>> scene = build_scene(scenario, robots=False)
        >>> forces = TissueForces(scene.model, scenario.material, scene.aponeurosis,
        ...                       scene.tissue_bodies)
        >>> data = mujoco.MjData(scene.model)
        >>> force_n, moment_nm = forces.apply(data)  # before every mj_step
        >>> forces.reset()  # with a new state: the springs' history back at rest
    """

    def __init__(self, model: mujoco.MjModel, material: ContinuumMaterial | MassSpringMaterial,
                 aponeurosis: Aponeurosis, bodies: np.ndarray, implicit: bool = False,
                 law_refresh_steps: int = 1) -> None:
        self.aponeurosis = aponeurosis
        self.implicit = implicit
        self.dofs = tissue_dofs(model, bodies)
        self.springs: dict[str, MassSpringModel] = (
            {muscle: MassSpringModel(model, (muscle,), material, implicit=implicit,
                                     law_refresh_steps=law_refresh_steps)
             for muscle in MUSCLES}
            if isinstance(material, MassSpringMaterial) else {})

    def apply(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """Write the tissue forces for the state in ``data``; returns the pull on the blade."""
        with part("tissue law"):
            if not self.springs:
                data.qfrc_applied[self.dofs] = 0.0
            for springs in self.springs.values():
                springs.apply(data, filtered=False)  # rewrites its muscle's dofs' entries
        with part("bindings"):
            on_blade = self.aponeurosis.apply_forces(data)
        with part("implicit solve"):
            for springs in self.springs.values():
                springs.filter(data)  # the bindings' forces go through the implicit step too
        return on_blade

    def reset(self) -> None:
        """Every spring back at rest: no plastic strain, nothing left to relax."""
        for springs in self.springs.values():
            springs.reset()

    def stable_timestep_s(self, safety: float = 0.9) -> float | None:
        """The springs' stable step (:meth:`MassSpringModel.stable_timestep_s`), s; None for a
        continuum material or the implicit step (stable at any step)."""
        if not self.springs or self.implicit:
            return None
        return min(springs.stable_timestep_s(safety) for springs in self.springs.values())
