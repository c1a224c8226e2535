"""Stepping the cell: physics, binding release rules, the grasp, sensors, divergence checks;
and the same physics step on the muscles alone (:class:`TissueSimulation`)."""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from cell.errors import MaterialError, ScenarioError
from cell.profiling import part, timed
from cell.robots.names import GRASP_SITE, GRIPPER_BODY, KNIFE_BLADE_GEOM
from cell.sim.assembly import Scene
from cell.sim.divergence import FATAL_WARNINGS, check_state, fatal_warnings
from cell.sim.dynamometer import Dynamometer, contact_load
from cell.sim.scenario import Scenario
from cell.tissue.aponeurosis import ReleaseRule
from cell.tissue.cutting import EdgeResistance
from cell.tissue.forcecurve import ForceCurve
from cell.tissue.forces import TissueForces
from cell.tissue.massspring import MassSpringModel
from cell.tissue.seamcut import SeamCut

_SENSORS_OFF = int(mujoco.mjtDisableBit.mjDSBL_SENSOR)


class TissueSimulation:
    """The physics step of the two muscles: the tissue forces MuJoCo does not compute
    (:class:`~cell.tissue.forces.TissueForces`), ``mj_step``, and the divergence check.

    It runs on a scene without robots (``build_scene(scenario, robots=False)``: the tissue
    bench) and is the base of the cell's :class:`Simulation`, which adds the knife, the
    grasp and the sensors. A new simulation restores the scene (:meth:`Scene.restore`), so
    a scene serves one episode after another.

    Attributes:
        scene: the compiled scene.
        model: its model.
        data: the state.
        tissue: the tissue forces.

    Example:
        >>> from cell.sim.assembly import build_scene
        >>> from cell.sim.scenario import Scenario
        >>> from cell.tissue.geometry import MuscleShape
        >>> scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05))
        >>> sim = TissueSimulation(build_scene(scenario, robots=False), scenario)
        >>> sim.step(10)
        >>> sim.reset()  # back to rest, the springs' history too
    """

    def __init__(self, scene: Scene, scenario: Scenario) -> None:
        self.scene = scene
        self.scenario = scenario
        self.model = scene.model
        self.data = mujoco.MjData(self.model)
        scene.restore(self.data)
        self.tissue = TissueForces(self.model, scenario.material, scene.aponeurosis,
                                   scene.tissue_bodies,
                                   implicit=scenario.simulation.tissue_step == "implicit",
                                   law_refresh_steps=scenario.simulation.control_substeps)
        self._warnings = np.zeros(len(FATAL_WARNINGS), dtype=int)
        # The force sensors' pass over every body (mj_rnePostConstraint) is a sizable share
        # of a step of the bare muscles, and their readings are read after a call to step() or
        # forward() only: MuJoCo computes them in those calls' last pass alone.
        self.model.opt.disableflags |= _SENSORS_OFF

    @property
    def time_s(self) -> float:
        """Simulated time, s."""
        return float(self.data.time)

    @property
    def springs(self) -> dict[str, MassSpringModel]:
        """The mass-spring model of each muscle (none for a continuum material)."""
        return self.tissue.springs

    def reset(self, state: mujoco.MjData | None = None) -> None:
        """Back to rest, or to a copy of ``state``: a new state (its warnings counted from
        here), the springs' history at rest, the scene restored."""
        self.data = mujoco.MjData(self.model)
        self.scene.restore(self.data)
        if state is not None:
            mujoco.mj_copyData(self.data, self.model, state)
        self.tissue.reset()
        self._warnings = fatal_warnings(self.data)

    def step(self, count: int = 1, sensors: bool = True) -> None:
        """Advance ``count`` physics steps, then check for divergence; MuJoCo computes the
        sensors in the last of them (with ``sensors``) or in none (a caller stepping one at a
        time asks for them in the step it reads after).

        Before each step the forces that MuJoCo does not compute itself (mass-spring
        springs, binding springs, hooked bindings on the blade) are written from the present
        state. A blow-up inside the ``count`` steps is caught after them: MuJoCo's warning
        counters and the non-finite state persist.
        """
        start = self.time_s
        for index in range(count):
            self._apply_forces()
            with part("MuJoCo step"):
                if index < count - 1 or not sensors:
                    mujoco.mj_step(self.model, self.data)
                else:
                    self._with_sensors(mujoco.mj_step)
        self.check_divergence(start + count * self.model.opt.timestep)

    def forward(self) -> None:
        """``mj_forward`` on the present state, the sensors' readings with it."""
        self._with_sensors(mujoco.mj_forward)

    def _with_sensors(self, stage: Callable[[mujoco.MjModel, mujoco.MjData], None]) -> None:
        model = self.model
        model.opt.disableflags &= ~_SENSORS_OFF
        try:
            stage(model, self.data)
        finally:
            model.opt.disableflags |= _SENSORS_OFF

    def _apply_forces(self) -> None:
        self.tissue.apply(self.data)

    @timed("divergence check")
    def check_divergence(self, time_s: float | None = None) -> None:
        """Raise :class:`~cell.errors.DivergenceError` on NaN, a fatal MuJoCo warning since
        the last check or runaway tissue (:func:`~cell.sim.divergence.check_state`);
        ``time_s``: the time the step should have reached."""
        counts = fatal_warnings(self.data)
        try:
            check_state(self.data, self.tissue.dofs, self._warnings,
                        self.scenario.simulation.max_tissue_speed_m_s,
                        self.time_s if time_s is None else time_s)
        finally:
            self._warnings = counts


class Simulation(TissueSimulation):
    """The scene's physics with the episode's rules applied between control steps.

    Sensor readings are tared at :meth:`tare` (the tool's own weight) and carry the noise of
    ``scenario.sensors``, drawn from the scenario's seed.

    Example:
        >>> from cell.sim.assembly import build_scene
        >>> from cell.sim.scenario import Scenario
        >>> from cell.tissue.geometry import MuscleShape
        >>> scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05))
        >>> sim = Simulation(build_scene(scenario), scenario)
        >>> sim.step(10)
        >>> {rule.value: len(i) for rule, i in sim.apply_release_rules().items()}  # no cut yet
        {'tearing': 0}
        >>> sim.knife_load_n()  # the knife is far from the meat
        {'bindings': 0.0, 'flesh': 0.0, 'edge': 0.0, 'faces': 0.0}
    """

    def __init__(self, scene: Scene, scenario: Scenario) -> None:
        super().__init__(scene, scenario)
        self.rng = np.random.default_rng(scenario.seed)
        self._sensor = {name: self._sensor_slice(name) for name in (
            "knife/force", "knife/torque", "gripper/force", "gripper/torque", "fixture_force")}
        self._sensor_site = {name: int(self.model.sensor(name).objid[0])
                             for name in self._sensor}
        # The tools' force/torque sensors: their site, and the bodies whose load they carry.
        self._tool_sensor = {name: self._tool_of(name) for name in (
            "knife/force", "knife/torque", "gripper/force", "gripper/torque")}
        self._flex_load: dict[int, tuple[float, np.ndarray, np.ndarray]] = {}
        self._tare = {name: np.zeros(3) for name in self._sensor}
        self.dynamometer = Dynamometer(self.model, scene.aponeurosis)
        self._blade = self.model.geom(KNIFE_BLADE_GEOM).id
        self._knife = self.model.geom_bodyid[self._blade]
        self._gripper = self.model.body(GRIPPER_BODY).id
        self._grasp_site = self.model.site(GRASP_SITE).id
        self.grasped = np.zeros(0, dtype=int)
        stable = self.tissue.stable_timestep_s()  # None for the implicit step: no bound
        if stable is not None and self.model.opt.timestep > stable:
            raise ScenarioError(None, "simulation.timestep_s",
                                f"{self.model.opt.timestep} s is above the stable step "
                                f"{stable:.3g} s of this mass-spring material and mesh "
                                "(simulation.tissue_step = \"implicit\" has no bound)")
        params = scenario.aponeurosis
        by_model = params.knife_force == "cutting"
        self.force_curve = (ForceCurve.from_csv(params.force_curve) if not by_model and (
            ReleaseRule.FORCE.value in params.release_rules or params.edge_share > 0) else None)
        # The material's cutting model in the seam, or a share of the curve at the edge.
        self.seam = (SeamCut(params.cutting(scenario.material.cutting), scene.mesh.top_line,
                             float(scene.mesh.origin_m[2]), params.toughness_gradient)
                     if by_model else None)
        self.edge = EdgeResistance(self.model)
        self._edge_force_n = 0.0  # the curve's share the edge meets until the next check, N
        self._cutting_n = 0.0  # the seam's force to cut where the edge was at the last step, N
        self._on_blade = {"bindings": np.zeros(3), "edge": np.zeros(3), "faces": np.zeros(3)}
        self._lever_moment = np.zeros(3)

    def reset(self, state: mujoco.MjData | None = None) -> None:
        """Back to rest (or to a copy of ``state``) as a new simulation starts: the tissue's
        reset, no grasp, the sensors untared and their noise drawn again from the seed."""
        super().reset(state)
        self.rng = np.random.default_rng(self.scenario.seed)
        self._tare = {name: np.zeros(3) for name in self._sensor}
        self._flex_load = {}
        self.grasped = np.zeros(0, dtype=int)
        self.edge.reset()
        if self.seam is not None:
            self.seam.reset()
        self._edge_force_n = self._cutting_n = 0.0
        self._on_blade = {"bindings": np.zeros(3), "edge": np.zeros(3), "faces": np.zeros(3)}

    def _sensor_slice(self, name: str) -> slice:
        sensor = self.model.sensor(name)
        start = int(sensor.adr[0])
        return slice(start, start + int(sensor.dim[0]))

    def _tool_of(self, name: str) -> tuple[int, np.ndarray]:
        """The site of the force or torque sensor ``name`` and the bodies below it (the tool
        it weighs)."""
        model = self.model
        site = self._sensor_site[name]
        top = model.site_bodyid[site]
        below = [body for body in range(model.nbody) if self._descends(body, top)]
        return site, np.array(below)

    def _descends(self, body: int, ancestor: int) -> bool:
        while body != ancestor and body != 0:
            body = self.model.body_parentid[body]
        return body == ancestor

    def flex_contact_load(self, bodies: np.ndarray, point_m: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray]:
        """Force (N) and moment about ``point_m`` (N m) that the flex contacts (the muscles'
        vertices) put on the geoms of ``bodies``, world frame. MuJoCo 4.0 leaves these
        contacts out of ``cfrc_ext``, so out of its force and torque sensors: the knife body's
        ``cfrc_ext`` equals its ``xfrc_applied`` while the blade presses into the flesh."""
        model, data, count = self.model, self.data, self.data.ncon
        if count == 0:
            return np.zeros(3), np.zeros(3)
        geoms, flexes = data.contact.geom[:count], data.contact.flex[:count]
        member = np.zeros(model.nbody, bool)
        member[bodies] = True
        on_tool = (geoms >= 0) & member[model.geom_bodyid[np.maximum(geoms, 0)]]
        on_tool &= (flexes >= 0).any(axis=1)[:, None]
        return contact_load(model, data, on_tool, point_m)

    def _tool_flex_load(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`flex_contact_load` on the tool of sensor ``name``, about its site; computed
        once per physics time for each site (the sensors and the knife's load split share
        it)."""
        site, bodies = self._tool_sensor[name]
        cached = self._flex_load.get(site)
        if cached is None or cached[0] != self.data.time:
            cached = (self.data.time, *self.flex_contact_load(bodies, self.data.site_xpos[site]))
            self._flex_load[site] = cached
        return cached[1], cached[2]

    def _raw(self, name: str) -> np.ndarray:
        """Sensor ``name``'s reading, the flex contacts on a tool added as a real
        force/torque sensor feels them (the load on the tool pulls on the sensor: minus)."""
        value = self.data.sensordata[self._sensor[name]]
        if name not in self._tool_sensor:  # the fixture: what the round carries from elsewhere
            missing = self.dynamometer.missing_load(self.data)
            return value - self.data.site_xmat[self._sensor_site[name]].reshape(3, 3).T @ missing
        force, moment = self._tool_flex_load(name)
        load = moment if name.endswith("torque") else force
        site = self._tool_sensor[name][0]
        return value - self.data.site_xmat[site].reshape(3, 3).T @ load

    @timed("cutting terms")  # the tissue's parts inside it timed as theirs
    def _apply_forces(self) -> None:
        data = self.data
        blade_pos, blade_mat = data.geom_xpos[self._blade], data.geom_xmat[self._blade]
        self.scene.aponeurosis.track_blade(blade_pos, blade_mat)
        hooks, moment = self.tissue.apply(data)
        half = self.model.geom_size[self._blade]
        velocity = np.zeros(6)
        if self._edge_force_n or self.seam is not None:
            mujoco.mj_objectVelocity(self.model, data, mujoco.mjtObj.mjOBJ_GEOM, self._blade,
                                     velocity, 0)
        if self.seam is not None:
            seam = self.seam.load(blade_pos, blade_mat, half, velocity[3:])
            self.edge.load(data, seam.on_blade_n, blade_pos, blade_mat, half)
            self._cutting_n = seam.resistance_n
            self._on_blade = {"bindings": hooks, "edge": seam.edge_n, "faces": seam.faces_n}
            force, moment = hooks + seam.on_blade_n, moment + seam.moment_nm
        else:
            edge, edge_moment = self.edge.apply(data, self._edge_force_n, blade_pos, blade_mat,
                                                half, velocity[3:])
            self._on_blade = {"bindings": hooks, "edge": edge, "faces": np.zeros(3)}
            force, moment = hooks + edge, moment + edge_moment
        if force.any() or data.xfrc_applied[self._knife].any():
            # xfrc_applied acts at the knife's centre of mass, the hooks' and the edge's
            # moments are about the blade centre. mju_cross: np.cross is dear on one vector.
            mujoco.mju_cross(self._lever_moment, blade_pos - data.xipos[self._knife], force)
            data.xfrc_applied[self._knife, :3] = force
            data.xfrc_applied[self._knife, 3:] = moment + self._lever_moment

    def set_fibre_direction(self, muscle: str, direction: np.ndarray) -> None:
        """Turn the fibres of ``muscle`` (``"round"`` or ``"shank"``) to ``direction`` (world
        frame), as the vision module would after looking at the meat.

        Raises:
            MaterialError: a zero direction, or a continuum material (it has no fibres).
        """
        if muscle not in self.springs:
            raise MaterialError(None, "fibre_direction",
                                f"no mass-spring muscle named {muscle!r} (the continuum "
                                "materials are isotropic)")
        self.springs[muscle].set_fibre_direction(direction)

    @timed("release rules")
    def apply_release_rules(self, knife_time_s: float | None = None
                            ) -> dict[ReleaseRule, np.ndarray]:
        """Release bindings by the scenario's rules; returns the indices released per rule.

        ``knife_time_s`` is the time since the knife began cutting (None when it does not
        cut). The force rule's cutting force is the seam's force to cut where the edge is
        (``knife_force = "cutting"``: :class:`~cell.tissue.seamcut.SeamCut`), or the measured
        curve's at that time, of which the blade's edge meets its ``edge_share`` until the
        next call (``"curve"``: :class:`EdgeResistance`).
        """
        params = self.scenario.aponeurosis
        apo = self.scene.aponeurosis
        rules = params.release_rules
        released: dict[ReleaseRule, np.ndarray] = {}
        under_blade = apo.under_blade(
            self.data, self.data.geom_xpos[self._blade], self.data.geom_xmat[self._blade],
            self.model.geom_size[self._blade], params.knife_margin_m)
        if ReleaseRule.KNIFE.value in rules:
            released[ReleaseRule.KNIFE] = apo.release_by_knife(self.data, self.time_s,
                                                               under_blade)
        if knife_time_s is None:
            cutting_n = 0.0
        elif self.seam is not None:
            cutting_n = self._cutting_n
        else:
            cutting_n = (params.force_scale * self.force_curve.at(knife_time_s)
                         if self.force_curve is not None else 0.0)
        self._edge_force_n = 0.0 if self.seam is not None else params.edge_share * cutting_n
        if ReleaseRule.FORCE.value in rules and knife_time_s is not None:
            apo.hook(self.data, under_blade)
            threshold = params.force_share * cutting_n
            released[ReleaseRule.FORCE] = apo.release_by_force(self.data, self.time_s,
                                                               under_blade, threshold)
        if ReleaseRule.TEARING.value in rules:
            released[ReleaseRule.TEARING] = apo.release_by_tearing(
                self.data, self.time_s, params.tearing_stretch_m,
                params.tearing_force_n or None)
        return released

    @timed("sensing")
    def knife_load_n(self) -> dict[str, float]:
        """How the force on the knife splits, N (norms of world-frame vectors): ``bindings``
        hooked on the edge, ``flesh`` pushing on the knife (its flex contacts), the
        ``edge``'s cutting resistance and the ``faces``' friction in the cut (the cutting
        model's, :class:`~cell.tissue.seamcut.SeamCut`; none from a curve)."""
        contacts, _ = self._tool_flex_load("knife/force")
        return {"bindings": float(np.linalg.norm(self._on_blade["bindings"])),
                "flesh": float(np.linalg.norm(contacts)),
                "edge": float(np.linalg.norm(self._on_blade["edge"])),
                "faces": float(np.linalg.norm(self._on_blade["faces"]))}

    def grasp(self, jaw_half_size_m: np.ndarray) -> int:
        """Bind the shank vertices inside the jaw box (centred on the grasp site, in its frame)
        to the gripper where they are now; returns how many were bound."""
        model, data, scene = self.model, self.data, self.scene
        bodies = scene.shank_bodies[scene.grasp_vertices]
        site_pos = data.site_xpos[self._grasp_site]
        site_rot = data.site_xmat[self._grasp_site].reshape(3, 3)
        local = (data.xpos[bodies] - site_pos) @ site_rot
        inside = np.all(np.abs(local) <= jaw_half_size_m, axis=1)
        gripper_pos = data.xpos[self._gripper]
        gripper_rot = data.xmat[self._gripper].reshape(3, 3)
        for eq, body in zip(scene.grasp_equalities[inside], bodies[inside], strict=True):
            model.eq_data[eq, 0:3] = (data.xpos[body] - gripper_pos) @ gripper_rot
            model.eq_data[eq, 3:6] = 0.0
            data.eq_active[eq] = 1
        self.grasped = scene.grasp_equalities[inside]
        return int(inside.sum())

    @timed("sensing")
    def tare(self, *names: str) -> None:
        """Zero sensors (all by default) at the present load, such as a tool's own weight."""
        for name in names or tuple(self._sensor):
            self._tare[name] = self._raw(name)

    def read_world(self, name: str) -> np.ndarray:
        """:meth:`read` turned from the sensor's site frame into the world frame."""
        site = self._sensor_site[name]
        return self.data.site_xmat[site].reshape(3, 3) @ self.read(name)

    @timed("sensing")
    def read(self, name: str, rng: np.random.Generator | None = None) -> np.ndarray:
        """A tared 3-vector sensor reading with the sensors' bias and noise: ``knife/force``,
        ``knife/torque``, ``gripper/force``, ``gripper/torque`` (N, N m, sensor frame) or
        ``fixture_force``; the noise drawn from ``rng`` (default: the sensors' own stream)."""
        params = self.scenario.sensors
        torque = name.endswith("torque")
        sigma = params.torque_noise_nm if torque else params.force_noise_n
        bias = np.asarray(params.torque_bias_nm if torque else params.force_bias_n)
        value = self._raw(name) - self._tare[name]
        return value + bias + (self.rng if rng is None else rng).normal(0.0, sigma, 3)
