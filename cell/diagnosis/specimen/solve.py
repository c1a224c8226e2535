"""A measured test, simulated quasi-statically with the muscles' own spring law.

The specimen is the spring lattice of its tet mesh (:func:`specimen_mesh`, the mirrored Kuhn
split the muscles use), every spring following :func:`~cell.tissue.springlaw.spring_stress`, the law
of the muscles' kernel, history included. Its platens are lubricated: the bottom face is held
along the load axis z, the top face follows the test's displacement, and both slide freely, so
the specimen deforms homogeneously. The deformation gradient is then

    F = [[a, 0, c], [0, b, 0], [0, 0, 1 + strain]]

(fibres in the x-z plane keep y a plane of symmetry; c is the shear a fibre at an angle to the
load gives), and every spring of one rest direction strains alike. Each sample solves, by
Newton's method, for the a, b, c at which the lateral faces and the platens carry no traction
(the Kirchhoff stress ``sum_j w_j s_j r_j n_j n_j`` has only its zz entry; w_j the volume share of
the springs along rest direction j, s_j their stress, r_j their stretch, n_j their direction now),
commits the springs' history, and reads the axial force ``A tau_zz / (1 + strain)``.

Why quasi-static and homogeneous (measured in ``tests/diagnosis/specimen/test_solve.py`` against
:mod:`tests.specimen_reference`, the same springs in MuJoCo on a 6-cell mesh at the real mass and
half the stable step): the tests last minutes at strain rates of 1%/s, where inertia and the
springs' dashpots carry nothing, and the forces agree within 2%. One set of 10 tests takes
milliseconds instead of minutes, which is what lets a diagnosis refit the material hundreds of
times. The springs' dashpots (``damping_s``) are left out for that reason.

The lattice is calibrated (:func:`~cell.tissue.lattice.calibrated_law`) with the fibres along a
lattice axis, and keeps those factors at every fibre angle: a cubic lattice is not isotropic,
and recalibrating it for oblique fibres would give an isotropic material an angle dependence
that no tissue has.

Example:
    >>> from cell.measure.specimens import load_measurement_set
    >>> data = load_measurement_set("assets/measured/beef_round_example")
    >>> run = simulate_test(data.test("t00"), data.specimen, MassSpringMaterial.isotropic(6e3))
    >>> run.force_n.shape
    (250,)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cell.errors import DivergenceError
from cell.measure.specimens import MeasurementSet, MechanicalTest, Specimen
from cell.tissue.lattice import AffineLattice, affine_lattice, sheet_gain, tet_edges
from cell.tissue.material import MassSpringMaterial
from cell.tissue.packedlaw import SpringLaw
from cell.tissue.springlaw import homogeneous_stress
from cell.tissue.tetmesh import TetMesh, structured_hex_tets

# Cells along the specimen's longest edge; the homogeneous lattice only needs their shape.
_CELLS = 2
_LOAD_AXIS = (0.0, 0.0, 1.0)
# The sheets' direction at calibration: across the load axis, in the specimen's x-z plane.
_SHEET_AXIS = (1.0, 0.0, 0.0)
#: The displacement gradient's components a path gives (:func:`solve_path`), as strains.
_COMPONENTS = ("strain xx", "strain yy", "strain zz", "shear xz")
#: A uniaxial test's free components: the lateral stretches and the shear of oblique fibres.
_UNIAXIAL_FREE = (0, 1, 3)


def specimen_mesh(specimen: Specimen, cells: int) -> TetMesh:
    """The specimen as a box of tets, ``cells`` along its longest edge, from the origin to
    ``size_m``: bottom face at z = 0, top face at z = ``size_m[2]``.

    Example:
        >>> len(specimen_mesh(Specimen("cube", (0.01, 0.01, 0.01)), 2).tets)
        48
    """
    size = np.asarray(specimen.size_m)
    counts = tuple(max(1, round(cells * s / size.max())) for s in size)
    axes = [np.linspace(0.0, s, n + 1) for s, n in zip(size, counts, strict=True)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return TetMesh.from_arrays(grid, structured_hex_tets(counts), specimen.name)


def fibre_direction(angle_deg: float) -> tuple[float, float, float]:
    """Unit fibre direction at ``angle_deg`` from the load axis z, in the x-z plane.

    Example:
        >>> [round(v, 6) for v in fibre_direction(90.0)]
        [1.0, 0.0, 0.0]
    """
    angle = math.radians(angle_deg)
    return (math.sin(angle), 0.0, math.cos(angle))


def sheet_direction(angle_deg: float) -> tuple[float, float, float]:
    """Unit sheet direction of fibres at ``angle_deg`` from z (:func:`fibre_direction`): across
    them in the x-z plane, the sheets' normal along y (the specimen's thickness).

    Example:
        >>> [round(v, 6) for v in sheet_direction(0.0)]
        [1.0, 0.0, 0.0]
    """
    angle = math.radians(angle_deg)
    return (math.cos(angle), 0.0, -math.sin(angle))


def turned(fibre: Sequence[float], sheet: Sequence[float], turn_deg: float
           ) -> tuple[np.ndarray, np.ndarray]:
    """The fibre and sheet directions turned by ``turn_deg`` about the sheets' normal, the
    fibres towards the sheets (the turn of :func:`fibre_turn_deg`).

    Example:
        >>> [v.round(6).tolist() for v in turned((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), 90.0)]
        [[1.0, 0.0, 0.0], [-0.0, 0.0, -1.0]]
    """
    angle = math.radians(turn_deg)
    fibre, sheet = np.asarray(fibre, dtype=float), np.asarray(sheet, dtype=float)
    return (math.cos(angle) * fibre + math.sin(angle) * sheet,
            math.cos(angle) * sheet - math.sin(angle) * fibre)


def fibre_turn_deg(material: MassSpringMaterial) -> float:
    """How far ``material``'s fibres are turned from the fibre axis a test declares, degrees:
    the angle of its ``fibre_direction`` from x towards z (a diagnosis's materials have their
    fibres along x and their sheets along z, as the candidate material builds them; the cause
    ``fibre_direction`` turns both about their normal).

    Example:
        >>> round(fibre_turn_deg(MassSpringMaterial(fibre_direction=(1.0, 0.0, 1.0))), 6)
        45.0
    """
    fibre = material.fibre_direction
    return math.degrees(math.atan2(fibre[2], fibre[0]))


def _grouped(units: np.ndarray, volume_m3: np.ndarray, total_m3: float, mirror: bool
             ) -> tuple[np.ndarray, np.ndarray]:
    """The unit rest directions of springs ``units`` (E, 3) grouped, with each group's volume
    share (``volume_m3`` summed over the group, over ``total_m3``): springs strain alike when
    parallel (either sign) and, with ``mirror``, when mirror images across y = 0 (where F, the
    fibres and the sheets keep it a plane of symmetry)."""
    units = units.copy()
    if mirror:
        units[:, 1] = np.abs(units[:, 1])
    signed = [0, 2] if mirror else [0, 1, 2]
    part = units[:, signed]
    lead = part[np.arange(len(units)), np.argmax(np.abs(part) > 1e-9, axis=1)]
    units[:, signed] *= np.where(lead < 0.0, -1.0, 1.0)[:, None]
    keys, group = np.unique(np.round(units, 9), axis=0, return_inverse=True)
    return (keys / np.linalg.norm(keys, axis=1, keepdims=True),
            np.bincount(group.ravel(), weights=volume_m3) / total_m3)


@dataclass(frozen=True, eq=False)
class SpecimenLattice:
    """The specimen's springs grouped by rest direction, for homogeneous deformation.

    Attributes:
        directions: (J, 3) unit rest directions, one per group of parallel springs.
        weights: (J,) each group's volume share, ``sum(sum(V)) / V`` over its springs
            (dimensionless; ``K0 l0**2 = sum(V)`` for every spring).
        parallel_directions: (J', 3) and
        parallel_weights: (J',) the same with only parallel springs grouped, for fibres or
            sheets that leave y no plane of symmetry (:func:`solve_path`).
        mesh: the specimen's mesh.
        edges: (E, 2) its springs.
        edge_volume_m3: (E,) volume of the tets sharing each spring, m^3.

    Example:
        >>> lattice = SpecimenLattice.of(Specimen("cube", (0.01,) * 3))
        >>> len(lattice.directions), round(float(lattice.weights.sum()), 6)
        (9, 6.0)
        >>> len(lattice.parallel_directions), round(float(lattice.parallel_weights.sum()), 6)
        (13, 6.0)
    """

    directions: np.ndarray
    weights: np.ndarray
    parallel_directions: np.ndarray
    parallel_weights: np.ndarray
    mesh: TetMesh
    edges: np.ndarray
    edge_volume_m3: np.ndarray
    # Calibration factors and sheet factor by (El / Et, oblique, E_s / E_n), and the affine
    # lattices that calibrate by (oblique, orthotropic) and their geometry by orthotropy: they
    # depend on nothing else, and a diagnosis asks for the same ones thousands of times.
    _factors: dict[tuple[float, ...], tuple[float, float, float]] = field(
        default_factory=dict, repr=False)
    _affine: dict[tuple[float, bool], AffineLattice] = field(default_factory=dict, repr=False)
    _frames: dict[bool, AffineLattice] = field(default_factory=dict, repr=False)

    @classmethod
    def of(cls, specimen: Specimen) -> SpecimenLattice:
        """The lattice of ``specimen``: cubic cells whatever its proportions, as the muscles'
        (under homogeneous deformation its size only sets the area and the height; cells of
        its own proportions would make an isotropic material depend on the fibre angle)."""
        mesh = specimen_mesh(Specimen(specimen.name, (1.0, 1.0, 1.0)), _CELLS)
        edges, volume = tet_edges(mesh.points, mesh.tets)
        vectors = mesh.points[edges[:, 1]] - mesh.points[edges[:, 0]]
        units = vectors / np.linalg.norm(vectors, axis=1, keepdims=True)
        return cls(*_grouped(units, volume, mesh.volume_m3, True),
                   *_grouped(units, volume, mesh.volume_m3, False), mesh, edges, volume)

    def law(self, material: MassSpringMaterial) -> SpringLaw:
        """``material``'s spring law on this lattice, calibrated with its fibres along the load
        axis (as :func:`~cell.tissue.lattice.calibrated_law`, its factors remembered)."""
        squeezed = material.in_compression()
        tension = self._calibration(material)[:2]
        return SpringLaw.of(material, tension,
                            tension if material.symmetric else self._calibration(squeezed)[:2])

    def sheet_factor(self, material: MassSpringMaterial) -> float:
        """k of ``material``'s sheet gain on this lattice
        (:func:`~cell.tissue.lattice.sheet_factor`, fibres along the load axis, sheets
        across it); 1 for a transversely isotropic material."""
        return self._calibration(material)[2]

    def _calibration(self, material: MassSpringMaterial) -> tuple[float, float, float]:
        key = (material.longitudinal.small_strain_modulus_pa
               / material.transverse.small_strain_modulus_pa, material.oblique,
               material.sheet_over_normal)
        return _remembered(self._factors, key, lambda: self._calibrated(material))

    def _calibrated(self, material: MassSpringMaterial) -> tuple[float, float, float]:
        affine = _remembered(self._affine, (material.oblique, material.orthotropic),
                             lambda: self._frame(material).with_oblique(material.oblique))
        factor = affine.sheet_factor(material)
        return (*affine.calibration_factors(material, factor), factor)

    def _frame(self, material: MassSpringMaterial) -> AffineLattice:
        """An affine lattice of ``material``'s orthotropy, at any oblique factor."""
        return _remembered(self._frames, material.orthotropic,
                           lambda: affine_lattice(self.mesh.points, self.edges,
                                                  self.edge_volume_m3, material, _LOAD_AXIS,
                                                  _SHEET_AXIS))


def _remembered(store: dict[Any, Any], key: Any, make: Callable[[], Any]) -> Any:
    """``store[key]``, made by ``make()`` the first time (a store past 4096 entries starts
    over: a long diagnosis meets many keys once)."""
    if key not in store:
        if len(store) > 4096:
            store.clear()
        store[key] = make()
    return store[key]


@dataclass(frozen=True, eq=False)
class SimulatedTest:
    """The simulated force of one test.

    Attributes:
        test_id: the measured test's id.
        time_s: (n,) the test's sample times, s.
        force_n: (n,) simulated axial force on the top face at those times, N (+ pulls).
        lateral_stretch: (n, 2) a and b of the deformation gradient (x and y stretch).

    Example:
        >>> from cell.measure.specimens import MechanicalTest, Specimen
        >>> from cell.tissue.material import MassSpringMaterial
        >>> t = np.linspace(0.0, 10.0, 11)
        >>> test = MechanicalTest("t00", "tension", 0.0, t, 1e-5 * t, 0.0 * t)
        >>> cube = Specimen("cube", (0.01, 0.01, 0.01))
        >>> run = simulate_test(test, cube, MassSpringMaterial.isotropic(1e4))
        >>> round(float(run.force_n[-1]), 4)  # 10 kPa at 1 % strain on 1 cm^2: 0.01 N
        0.01
    """

    test_id: str
    time_s: np.ndarray
    force_n: np.ndarray
    lateral_stretch: np.ndarray

    @property
    def force_N(self) -> np.ndarray:
        """The name of :attr:`force_n` in 0.1.0 (a cut test's is ``force_n``), for one
        release."""
        return self.force_n


def simulate_test(
    test: MechanicalTest,
    specimen: Specimen,
    material: MassSpringMaterial,
    lattice: SpecimenLattice | None = None,
) -> SimulatedTest:
    """Simulate ``test`` on ``specimen`` made of ``material`` (module docstring).

    The material's fibres are turned to the test's ``angle_deg`` from the load axis, in the
    x-z plane, and by the material's own turn (:func:`fibre_turn_deg`) further. ``lattice``
    may be passed to reuse the specimen's.

    Raises:
        MaterialError: an anisotropy the lattice's springs cannot give.
        DivergenceError: no equilibrium at some sample (a spring collapsed).

    Example:
        >>> from cell.measure.specimens import load_measurement_set
        >>> from cell.tissue.material import MassSpringMaterial
        >>> data = load_measurement_set("assets/measured/beef_round_example")
        >>> run = simulate_test(data.test("c00"), data.specimen, MassSpringMaterial.isotropic(6e3))
        >>> run.force_n.shape
        (250,)
    """
    return simulate_tests((test,), specimen, material, lattice)[0]


def simulate_tests(
    tests: Sequence[MechanicalTest],
    specimen: Specimen,
    material: MassSpringMaterial,
    lattice: SpecimenLattice | None = None,
) -> list[SimulatedTest]:
    """:func:`simulate_test` for each of ``tests``, with one spring law (its calibration is
    most of the cost of a short test).

    Raises:
        MaterialError: an anisotropy the lattice's springs cannot give.
        DivergenceError: no equilibrium at some sample of a test (named).
    """
    lattice = SpecimenLattice.of(specimen) if lattice is None else lattice
    law = lattice.law(material)
    turn = fibre_turn_deg(material)
    runs = []
    for test in tests:
        strain = np.ascontiguousarray(test.strain(specimen))
        path = np.zeros((len(strain), 4))
        path[:, 2] = strain
        tau, gradient = solve_path(lattice, law, test.test_id, test.time_s, path,
                                   _UNIAXIAL_FREE, fibre_direction(test.angle_deg + turn),
                                   sheet_direction(test.angle_deg + turn),
                                   lattice.sheet_factor(material))
        runs.append(SimulatedTest(test.test_id, test.time_s,
                                  tau[:, 2] / (1.0 + strain) * test.area_m2(specimen),
                                  gradient[:, :2]))
    return runs


def solve_path(lattice: SpecimenLattice, law: SpringLaw, test_id: str, time_s: np.ndarray,
               path: np.ndarray, free: Sequence[int], fibre: Sequence[float],
               sheet: Sequence[float] = _SHEET_AXIS, sheet_factor: float = 1.0
               ) -> tuple[np.ndarray, np.ndarray]:
    """The homogeneous lattice along ``path`` ((n, 4): the displacement gradient F - I's xx,
    yy, zz and xz at the samples of ``time_s``; F's other entries 0), the components listed in
    ``free`` solved for zero stress in the same components, fibres along ``fibre``, sheets
    along ``sheet`` with the springs' sheet gain ``sheet_factor`` (the free components keep y
    a plane of symmetry; where the fibres or sheets leave it one, only parallel springs are
    grouped) (:func:`~cell.tissue.springlaw.homogeneous_stress`): the Kirchhoff stress
    (n, 4; xx, yy, zz, xz; Pa) and F (n, 4; xx, yy, zz, xz) at the samples.

    Raises:
        DivergenceError: no equilibrium at some sample (naming ``test_id``).
    """
    fibre, sheet = np.asarray(fibre, dtype=float), np.asarray(sheet, dtype=float)
    directions, weights = ((lattice.directions, lattice.weights)
                           if _mirrored(fibre) and _mirrored(sheet) else
                           (lattice.parallel_directions, lattice.parallel_weights))
    cos_sq = (directions @ fibre) ** 2
    if sheet_factor != 1.0:
        weights = weights * sheet_gain(sheet_factor, (directions @ sheet) ** 2)
    time = np.ascontiguousarray(time_s - time_s[0])
    path = np.ascontiguousarray(path, dtype=float)
    tau, gradient = np.empty((len(time), 4)), np.empty((len(time), 4))
    failed = homogeneous_stress(time, path, np.asarray(free, dtype=np.int64),
                                directions, weights, cos_sq, law.curves, law.params,
                                law.history(len(directions)), tau, gradient)
    if failed >= 0:
        moved = ", ".join(f"{name} {path[failed, i]:.4g}" for i, name in enumerate(_COMPONENTS)
                          if i not in free and path[failed, i] != 0.0)
        raise DivergenceError(float(time[failed]), f"test {test_id!r}: the specimen has no "
                              f"equilibrium at {moved or 'rest'}")
    return tau, gradient


def _mirrored(direction: np.ndarray) -> bool:
    """Whether ``direction`` keeps y a plane of symmetry (in the x-z plane, or along y)."""
    return abs(direction[1]) < 1e-12 or (abs(direction[0]) < 1e-12 and abs(direction[2]) < 1e-12)


def simulate_set(measurements: MeasurementSet,
                 material: MassSpringMaterial) -> tuple[SimulatedTest, ...]:
    """Simulate every test of a set, in its order, on one lattice.

    Example:
        >>> from cell.measure.specimens import load_measurement_set
        >>> from cell.tissue.material import MassSpringMaterial
        >>> data = load_measurement_set("assets/measured/beef_round_example")
        >>> len(simulate_set(data, MassSpringMaterial.isotropic(6e3)))
        20
    """
    return tuple(simulate_tests(measurements.tests, measurements.specimen, material))
