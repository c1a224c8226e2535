"""What MuJoCo's force sensors leave out, added back: the flex contacts and the spring
bindings.

MuJoCo 4.0 counts neither the contacts of a flex (the muscles' vertices) nor forces written
into ``qfrc_applied`` in the external forces (``cfrc_ext``) from which its force and torque
sensors are computed. A tool's sensor so misses the flesh pressing on the tool
(:func:`contact_load` adds it), and the fixture's dynamometer, whose subtree holds the round,
misses every load on the round that is not in ``cfrc_ext``: the flesh's contacts with the
tools and the bindings' pull on the round (:class:`Dynamometer` adds them).
"""

from __future__ import annotations

import mujoco
import numpy as np

from cell.tissue.aponeurosis import Aponeurosis


def contact_load(model: mujoco.MjModel, data: mujoco.MjData, on_object: np.ndarray,
                 point_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Force (N) and moment about ``point_m`` (N m), world frame, that the contacts put on
    an object; ``on_object`` (ncon, 2) says which side of each contact is the object (a
    contact with the object on both sides, or on neither, adds nothing).

    Example:
        >>> model = mujoco.MjModel.from_xml_string(
        ...     '<mujoco><worldbody><geom type="plane" size="1 1 1"/><body pos="0 0 0.1">'
        ...     '<freejoint/><geom size="0.1" mass="1"/></body></worldbody></mujoco>')
        >>> data = mujoco.MjData(model)
        >>> for _ in range(200):
        ...     mujoco.mj_step(model, data)
        >>> on_ball = np.array([[False, True]])  # the plane is geom 1 of the contact
        >>> force, _ = contact_load(model, data, on_ball, np.zeros(3))
        >>> round(float(force[2]), 2)  # the floor carries the ball's weight
        9.81
    """
    which = np.flatnonzero(on_object[:, 0] != on_object[:, 1])
    if len(which) == 0:
        return np.zeros(3), np.zeros(3)
    # The contact frame's first row is the normal, from side 1 to side 2, and the force it
    # gives acts on side 2.
    frames = data.contact.frame[which].reshape(-1, 3, 3)
    world = np.einsum("nij,ni->nj", frames, contact_forces(model, data, which))
    world[~on_object[which, 1]] *= -1.0
    moment = np.cross(data.contact.pos[which] - point_m, world)
    return world.sum(axis=0), moment.sum(axis=0)


def contact_forces(model: mujoco.MjModel, data: mujoco.MjData, which: np.ndarray
                   ) -> np.ndarray:
    """(len(which), 3) force of each contact ``which`` in its contact frame (normal, then
    the two tangents), N: what ``mujoco.mj_contactForce`` gives, read for all of them at
    once from ``data.efc_force`` (a pyramidal cone's edges summed into the normal and
    differenced into the tangents, as MuJoCo decodes them).

    Example:
        >>> model = mujoco.MjModel.from_xml_string(
        ...     '<mujoco><worldbody><geom type="plane" size="1 1 1"/><body pos="0 0 0.1">'
        ...     '<freejoint/><geom size="0.1" mass="1"/></body></worldbody></mujoco>')
        >>> data = mujoco.MjData(model)
        >>> for _ in range(200):
        ...     mujoco.mj_step(model, data)
        >>> wrench = np.zeros(6)
        >>> mujoco.mj_contactForce(model, data, 0, wrench)
        >>> bool(np.allclose(contact_forces(model, data, np.array([0]))[0], wrench[:3]))
        True
    """
    contact = data.contact
    address, dim = contact.efc_address[which], contact.dim[which]
    forces = np.zeros((len(which), 3))
    pyramidal = model.opt.cone == mujoco.mjtCone.mjCONE_PYRAMIDAL
    for size in np.unique(dim[address >= 0]):
        rows = np.flatnonzero((dim == size) & (address >= 0))
        edges = data.efc_force[address[rows, None] + np.arange(2 * size - 2 if pyramidal
                                                                else size)]
        if not pyramidal or size == 1:
            forces[rows, :min(size, 3)] = edges[:, :3]
            continue
        forces[rows, 0] = edges.sum(axis=1)
        tangents = min(size - 1, 2)
        friction = contact.friction[which[rows], :tangents]
        forces[rows, 1:1 + tangents] = (edges[:, 0:2 * tangents:2]
                                        - edges[:, 1:2 * tangents:2]) * friction
    return forces


class Dynamometer:
    """The fixture's load cell: the load on the round that MuJoCo's ``fixture_force`` sensor
    leaves out (module docstring), to take off its reading.

    The sensor reads the force its body takes from the world, so a load the round carries
    from elsewhere (a knife pressing down, bindings pulling up) must be taken off: the
    fixture then holds the round's weight and those loads, as a real dynamometer under it.

    Args:
        model: the compiled scene.
        aponeurosis: the bindings (their round ends are on the fixture's side).

    Example:
        >>> from cell.sim.assembly import build_scene
        >>> from cell.sim.scenario import Scenario
        >>> from cell.tissue.geometry import MuscleShape
        >>> scene = build_scene(Scenario(tissue=MuscleShape(cell_size_m=0.05)), robots=False)
        >>> data = mujoco.MjData(scene.model)
        >>> mujoco.mj_forward(scene.model, data)
        >>> load = Dynamometer(scene.model, scene.aponeurosis).missing_load(data)
        >>> bool(np.allclose(load, 0.0))  # at rest the bindings pull on nothing
        True
    """

    def __init__(self, model: mujoco.MjModel, aponeurosis: Aponeurosis) -> None:
        self.model = model
        self.aponeurosis = aponeurosis
        self.round_flex = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_FLEX, "round")

    def missing_load(self, data: mujoco.MjData) -> np.ndarray:
        """The force on the round (N, world frame) that MuJoCo's sensor does not count: its
        flex contacts and the spring bindings on its vertices."""
        count = data.ncon
        load = self.aponeurosis.round_end_force(data)
        if count:
            on_round = data.contact.flex[:count] == self.round_flex
            load = load + contact_load(self.model, data, on_round, np.zeros(3))[0]
        return load
