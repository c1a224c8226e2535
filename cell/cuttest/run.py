"""A cut test simulated with the cell's knife model: the block of tissue stepped by the code
that steps the muscles, the blade driven along the test's logged edge path, the force on the
blade read as the measurement format's convention says.

The physics (scene: :mod:`cell.cuttest.scene`):

- the block's springs are the muscles' mass-spring model of the material file, under the
  implicit step (:class:`~cell.tissue.massspring.MassSpringModel`), gravity on, resting on
  the board through small spheres under its bottom vertices, as the cell's shank does;
- the **edge** term of the material's cutting model (:func:`~cell.tissue.cutmodel.edge_force`,
  toughness times the engaged length with its layer, rate, slicing and indentation factors)
  acts on the blade, read at each logged sample from the edge's position and velocity there
  (:func:`edge_term_n`); its reaction goes to the board, as if the tissue under the edge were
  rigid along the cut. Put on the tissue (on the vertices at the crack's tip, or spread over
  those ahead of the edge in proportion to their mass within a centimetre), it crushed the
  block: the spring lattice buckles in compression past a few kilopascals (a body load of ten
  times gravity, 3 kPa at the bottom of a 3 cm block of the default beef, flattened it),
  whereas the default toughness presses about 14 kPa on the block's footprint;
- the material **separates** behind the edge: a tie is released once the edge, in the block's
  rest frame, has come within the process zone of it. The process zone is one cell: the
  edge's wedge then always meets ties already released, so the ties carry no force of
  fracture (that is the edge term's, a property of the material), and what the mesh adds is
  the cut faces' contact on the blade, not a tearing of the mesh that would change with its
  cell size. The crack follows the edge's path through the rest frame (the depth the
  reduced model uses), not the deformed tissue;
- the **faces** press on the blade through MuJoCo's contacts (frictionless), and drag with
  the material's face law (:func:`~cell.tissue.cutmodel.face_friction_force`: ``mu p`` on
  each face) over the area of the cut that the blade is in, read on the mesh (the released
  ties above the edge, each with its share of the plane: :meth:`_Cut.face_area_m2`). The
  pressure p is the material's ``face_pressure_pa``, as in the reduced model, not the
  contacts': the mesh's contacts press on the blade with what the lattice's cells push
  across a blade thinner than one of them, far below the material's and changing with the
  cell size, a property of the mesh, whereas the faces' drag is the material's (the
  diagnosis page, "The faces of a cut").

The edge is engaged (cuts fresh material) while it sinks below the deepest point it has
reached; moving back out or along its own cut only the faces drag.

Signs: the measurement format gives the force that the block exerts on the blade; the cell's
knife sensor reads the force that the tool exerts on the sensor, the opposite sign:
:func:`knife_sensor_to_spec` is the one conversion.

Example:
    >>> import numpy as np
    >>> from cell.measure.cuts import Blade, Block
    >>> from cell.tissue.material import default_meat
    >>> from cell.tissue.cutmodel import CuttingParams
    >>> block = Block((0.04, 0.03, 0.02))
    >>> blade = Blade(0.1, 0.0015, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), 20.0)
    >>> time = np.linspace(0.0, 0.6, 7)
    >>> edge = np.stack([np.full(7, 0.02), np.full(7, 0.015), 0.022 - 0.01 * time], axis=1)
    >>> run = simulate_cut(time, edge, block, blade, default_meat(),
    ...                    CuttingParams(toughness_j_m2=300.0), CutSimulation(0.01))
    >>> bool(run.force_n[-1, 2] > 0.0)  # the block pushes the sinking blade up
    True
"""

from __future__ import annotations

import time as clock
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from cell.cuttest.scene import HALVES, CutScene, build_cut_scene, normal_axis
from cell.errors import InputError
from cell.measure.cuts import Blade, Block
from cell.measure.wedge import opening_strain, wedge_height_m
from cell.sim.divergence import check_state, fatal_warnings
from cell.tissue.cutmodel import (
    CuttingParams,
    edge_force,
    face_friction_force,
    path_velocity_m_s,
    push_and_slice,
)
from cell.tissue.edgestate import EdgeState, loaded_edge_force
from cell.tissue.massspring import MassSpringModel
from cell.tissue.material import MassSpringMaterial


def knife_sensor_to_spec(force_n: np.ndarray) -> np.ndarray:
    """The force the block (or meat) exerts on the blade, N, from the cell's knife sensor's
    reading (the force the tool exerts on the sensor), and back: the two differ in sign only,
    so the function is its own inverse.

    Example:
        >>> knife_sensor_to_spec(np.array([0.0, 0.0, -5.0])).tolist()
        [0.0, 0.0, 5.0]
    """
    return -np.asarray(force_n, dtype=float)


@dataclass(frozen=True)
class CutSimulation:
    """Settings of a cut test's full simulation.

    Attributes:
        cell_size_m: the block's mesh cell, m.
        timestep_s: the physics step, s.
        law_refresh_steps: physics steps per run of the spring law (the implicit step's, as
            the cell's control step).
        settle_s: time the block rests on the board before the path starts, s.
        board_friction: friction of the board under the block.
        max_tissue_speed_m_s: a vertex faster than this is a divergence, m/s.

    Example:
        >>> CutSimulation(cell_size_m=0.005).timestep_s
        0.002
    """

    cell_size_m: float = 0.005
    timestep_s: float = 2e-3
    law_refresh_steps: int = 2
    settle_s: float = 0.2
    board_friction: float = 1.0
    max_tissue_speed_m_s: float = 20.0

    def __post_init__(self) -> None:
        for name in ("cell_size_m", "timestep_s", "settle_s", "board_friction",
                     "max_tissue_speed_m_s"):
            if not getattr(self, name) >= 0 or (name != "settle_s" and not getattr(self, name)):
                raise InputError(None, name, f"must be > 0, got {getattr(self, name)}")
        if self.law_refresh_steps < 1:
            raise InputError(None, "law_refresh_steps", "must be >= 1")


@dataclass(frozen=True)
class SimulatedCut:
    """A simulated cut test, one row per logged sample, block frame, the format's sign.

    Attributes:
        time_s: (n,) the test's times, s.
        force_n: (n, 3) force the block exerts on the blade, N: ``edge_n + faces_n``.
        edge_n: (n, 3) the edge term's share, N.
        faces_n: (n, 3) the cut faces on the blade: their contacts' pressure and the face
            law's friction, N.
        released: (n,) ties released so far.
        ties: number of ties of the plane.
        nodes: tissue vertices of the mesh.
        wall_s: wall-clock time of the simulation, s.
    """

    time_s: np.ndarray
    force_n: np.ndarray
    edge_n: np.ndarray
    faces_n: np.ndarray
    released: np.ndarray
    ties: int
    nodes: int
    wall_s: float


def engaged_length_m(block: Block, centre_m: np.ndarray, edge_direction: np.ndarray,
                     length_m: float) -> float:
    """Length of the edge (``length_m`` long, along ``edge_direction``, centred at
    ``centre_m``) inside the block's rest box, m.

    Example:
        >>> engaged_length_m(Block((0.06, 0.04, 0.03)), np.array([0.03, 0.02, 0.01]),
        ...                  np.array([0.0, 1.0, 0.0]), 0.12)
        0.04
    """
    low, high = -length_m / 2, length_m / 2
    for k, size in enumerate(block.size_m):
        d, p = float(edge_direction[k]), float(centre_m[k])
        if abs(d) < 1e-12:
            if not 0.0 < p < size:
                return 0.0
            continue
        a, b = sorted(((0.0 - p) / d, (size - p) / d))
        low, high = max(low, a), min(high, b)
    return round(max(0.0, high - low), 12)


def edge_term_n(time_s: np.ndarray, edge_m: np.ndarray, block: Block, blade: Blade,
                cutting: CuttingParams, spine_direction: np.ndarray) -> np.ndarray:
    """(n, 3) the edge term on the blade at each logged sample, N: the cutting model at the
    edge's logged position and velocity there (the path's derivative, second order), where
    the edge sinks at the deepest point it has reached (it cuts fresh material).

    Example:
        >>> t = np.array([0.0, 1.0, 2.0])
        >>> edge = np.array([[0.02, 0.015, 0.021], [0.02, 0.015, 0.011], [0.02, 0.015, 0.001]])
        >>> force = edge_term_n(t, edge, Block((0.04, 0.03, 0.02)), Blade(0.1, 0.001,
        ...     (0.0, 1.0, 0.0), (1.0, 0.0, 0.0)), CuttingParams(500.0), np.array([0.0, 0.0, 1.0]))
        >>> (force[:, 2] + 0.0).tolist()  # in air, then 500 J/m^2 over the 0.03 m block
        [0.0, 15.0, 15.0]
    """
    velocity = path_velocity_m_s(time_s, edge_m)
    edge_direction = np.asarray(blade.edge_direction)
    push, slide = push_and_slice(velocity, edge_direction, blade.blade_normal)
    spine = edge_m @ spine_direction
    fresh = (push @ spine_direction < 0.0) & (spine <= np.minimum.accumulate(spine))
    length = np.array([engaged_length_m(block, p, edge_direction, blade.edge_length_m)
                       for p in edge_m])
    depth = block.top_z_m - edge_m[:, 2]
    if cutting.loading_depth_m > 0.0 or cutting.edge_friction > 0.0:
        # The terms with a state, on the one strip of the edge in the box.
        inside = (length > 0.0)[:, None]
        return loaded_edge_force(cutting, EdgeState(
            (length * cutting.depth_factor(depth))[:, None], depth[:, None], inside,
            inside & fresh[:, None], push, slide, edge_m @ edge_direction, -spine_direction,
            edge_direction, depth))
    return edge_force(cutting, length * fresh, push, slide, depth)


def _spans(coordinate_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each point's interval on a grid's axis, m: halfway to its neighbours on the grid, the
    grid's ends at its first and last row.

    Example:
        >>> [v.tolist() for v in _spans(np.array([0.0, 0.01, 0.02, 0.01]))]
        [[0.0, 0.005, 0.015, 0.005], [0.005, 0.015, 0.02, 0.015]]
    """
    rounded = np.round(coordinate_m, 9)
    rows = np.unique(rounded)
    middles = (rows[1:] + rows[:-1]) / 2
    row = np.searchsorted(rows, rounded)
    return (np.concatenate([rows[:1], middles])[row],
            np.concatenate([middles, rows[-1:]])[row])


class _Cut:
    """The state of one cut's physics: the scene, the springs, the ties still bound."""

    def __init__(self, scene: CutScene, blade: Blade, material: MassSpringMaterial,
                 settings: CutSimulation) -> None:
        self.scene, self.blade, self.settings = scene, blade, settings
        self.model = scene.model
        self.data = mujoco.MjData(self.model)
        self.springs = MassSpringModel(self.model, HALVES, material, implicit=True,
                                       law_refresh_steps=settings.law_refresh_steps)
        free = self.springs.dofadr[self.springs.dofadr >= 0]
        self.tissue_dofs = (free[:, None] + np.arange(3)).ravel()
        points = scene.tie_points_m
        self.tie_spine = points @ scene.spine_direction
        self.tie_along = points @ scene.edge_direction
        self.tie_along_span = _spans(self.tie_along)
        self.tie_spine_span = _spans(self.tie_spine)
        self.bound = np.ones(len(scene.ties), dtype=bool)
        self.warnings = fatal_warnings(self.data).copy()

    def place_blade(self, position: np.ndarray, velocity: np.ndarray) -> None:
        scene, data = self.scene, self.data
        start = self.model.body_pos[scene.blade_body]
        data.qpos[scene.blade_qposadr:scene.blade_qposadr + 3] = position - start
        data.qvel[scene.blade_dofadr:scene.blade_dofadr + 3] = velocity

    def release(self, position: np.ndarray) -> None:
        """Release the ties the edge at ``position`` has come within the process zone of."""
        scene = self.scene
        zone = scene.cell_size_m
        along = position @ scene.edge_direction
        passed = ((self.tie_spine >= position @ scene.spine_direction - zone)
                  & (np.abs(self.tie_along - along) <= self.blade.edge_length_m / 2 + zone))
        newly = passed & self.bound
        if newly.any():
            self.data.eq_active[scene.ties[newly]] = 0
            self.bound &= ~newly

    def face_area_m2(self, position: np.ndarray) -> tuple[float, float]:
        """Area of one face of the blade (edge midpoint at ``position``) in the cut, m^2: the
        released ties' shares of the plane (halfway to their neighbours) between the edge and
        the spine's side, within the edge's length; and that area weighted by how far the
        blade opens the cut (:func:`~cell.measure.wedge.wedge_height_m`), m^2."""
        along = position @ self.scene.edge_direction
        half = self.blade.edge_length_m / 2
        low, high = self.tie_along_span
        width = np.clip(np.minimum(high, along + half) - np.maximum(low, along - half), 0, None)
        bottom, top = self.tie_spine_span
        edge = position @ self.scene.spine_direction
        above, below = np.clip(top - edge, 0, None), np.clip(bottom - edge, 0, None)
        released = ~self.bound
        opened = wedge_height_m(self.blade, above) - wedge_height_m(self.blade, below)
        return (float((width * (above - below))[released].sum()),
                float((width * opened)[released].sum()))

    def faces(self) -> np.ndarray:
        """The flex contacts' force on the blade, N (block frame). With elliptic cones a
        contact's ``efc_force`` rows are its force in the contact frame (normal first)."""
        data = self.data
        count = data.ncon
        if count == 0:
            return np.zeros(3)
        contact = data.contact
        on_blade = np.isin(contact.geom[:count], self.scene.blade_geoms)
        address = contact.efc_address[:count]
        chosen = np.flatnonzero(on_blade.any(axis=1) & (contact.flex[:count] >= 0).any(axis=1)
                                & (address >= 0))
        if len(chosen) == 0:
            return np.zeros(3)
        local = np.zeros((len(chosen), 3))
        local[:, 0] = data.efc_force[address[chosen]]
        rubs = contact.dim[chosen] >= 3
        for k in (1, 2):
            local[rubs, k] = data.efc_force[address[chosen][rubs] + k]
        world = np.einsum("nji,nj->ni", contact.frame[chosen].reshape(-1, 3, 3), local)
        # The contact's force acts on its second geom: the blade's when it is the second.
        return (world * np.where(on_blade[chosen, 1], 1.0, -1.0)[:, None]).sum(axis=0)

    def step(self) -> None:
        self.springs.apply(self.data)
        mujoco.mj_step(self.model, self.data)

    def check(self, time_s: float) -> None:
        """Raise :class:`~cell.errors.DivergenceError` if the block blew up
        (:func:`~cell.sim.divergence.check_state`)."""
        check_state(self.data, self.tissue_dofs, self.warnings,
                    self.settings.max_tissue_speed_m_s, time_s)


def simulate_cut(time_s: np.ndarray, edge_m: np.ndarray, block: Block, blade: Blade,
                 material: MassSpringMaterial, cutting: CuttingParams,
                 settings: CutSimulation = CutSimulation()) -> SimulatedCut:
    """Simulate the cut test whose edge midpoint passes ``edge_m`` (n, 3; m, block frame) at
    ``time_s`` (n,; s, increasing), and return the force on the blade at those times.

    The blade's plane passes through the path's median point. Between samples the edge moves
    in straight lines at constant speed.

    Raises:
        InputError: a path of fewer than two samples, time not increasing, a block that is
            not a box, or a blade whose plane the block's mesh cannot follow
            (:func:`~cell.cuttest.scene.normal_axis`).
        DivergenceError: the simulation blew up.
    """
    time_s = np.asarray(time_s, dtype=float)
    edge_m = np.asarray(edge_m, dtype=float)
    if block.section != "box":
        raise InputError(None, "section", f"the full simulation meshes box blocks only, got "
                         f"{block.section!r}")
    if len(time_s) < 2 or np.any(np.diff(time_s) <= 0) or edge_m.shape != (len(time_s), 3):
        raise InputError(None, "time_s", "a cut path needs >= 2 samples, time increasing, "
                         "one edge position (3) per sample")
    started = clock.perf_counter()
    scene = build_cut_scene(block, blade, material,
                            float(np.median(edge_m[:, normal_axis(blade)])),
                            settings.cell_size_m, edge_m[0], settings.board_friction,
                            settings.timestep_s)
    if block.fibre_direction is not None:
        material = replace(material, fibre_direction=block.fibre_direction)
    cut = _Cut(scene, blade, material, settings)
    dt = settings.timestep_s
    cut.place_blade(edge_m[0], np.zeros(3))
    mujoco.mj_forward(cut.model, cut.data)
    for _ in range(round(settings.settle_s / dt)):
        cut.place_blade(edge_m[0], np.zeros(3))
        cut.step()
    cut.check(0.0)
    steps = time_s[0] + dt * np.arange(1, int(np.ceil((time_s[-1] - time_s[0]) / dt)) + 1)
    # Each sample reads the faces' contacts of the step that starts nearest it.
    chosen = np.clip(np.round((time_s - time_s[0]) / dt).astype(int), 0, len(steps) - 1)
    read = np.zeros(len(steps), dtype=bool)
    read[chosen] = True
    face_log = np.zeros((len(steps), 3))
    area = np.zeros((len(steps), 2))
    released = np.zeros(len(steps), dtype=int)
    for k, end in enumerate(steps):
        start = end - dt
        segment = min(max(np.searchsorted(time_s, start, side="right") - 1, 0), len(time_s) - 2)
        velocity = ((edge_m[segment + 1] - edge_m[segment])
                    / (time_s[segment + 1] - time_s[segment]))
        position = edge_m[segment] + velocity * (start - time_s[segment])
        cut.place_blade(position, velocity)
        cut.release(position)
        cut.step()
        if read[k]:
            face_log[k] = cut.faces()
            area[k] = cut.face_area_m2(position)
            released[k] = int((~cut.bound).sum())
        if k % 50 == 49:
            cut.check(float(end))
    cut.check(float(steps[-1]))
    edge_n = edge_term_n(time_s, edge_m, block, blade, cutting, scene.spine_direction)
    push, slide = push_and_slice(path_velocity_m_s(time_s, edge_m), scene.edge_direction,
                                 blade.blade_normal)
    faces_n = face_log[chosen] + face_friction_force(cutting, area[chosen, 0], push, slide,
                                                     area[chosen, 1],
                                                     opening_strain(blade, block))
    return SimulatedCut(time_s.copy(), edge_n + faces_n, edge_n, faces_n,
                        released[chosen], len(scene.ties),
                        int(cut.springs.vertex_count), clock.perf_counter() - started)
