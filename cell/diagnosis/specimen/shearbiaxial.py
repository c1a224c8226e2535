"""Simple shear and biaxial tests simulated with the muscles' own spring law, as the uniaxial
tests are (:mod:`cell.diagnosis.specimen.solve`): the same homogeneous lattice and calibration,
the test's components of the deformation gradient F prescribed, the others solved for zero
traction (:func:`~cell.diagnosis.specimen.solve.solve_path`).

- ``shear`` (:class:`~cell.measure.shearbiaxial.ShearTest`): the plates are glued and their gap
  held, so ``F = I + gamma e_x e_z`` is prescribed whole (the lateral faces carry the
  complementary shear, as in every homogeneous reading of a simple shear test); the fibres lie
  along the axis that ``shear_plane`` names. The forces on the top plate are ``A tau_xz``
  along x and ``A tau_zz`` along z (``J = 1``: Kirchhoff and Cauchy stress agree).
- ``biaxial`` (:class:`~cell.measure.shearbiaxial.BiaxialTest`): the stretches along z and x are
  prescribed; the thickness (F_yy) and, for oblique fibres, the in-plane shear (F_xz) are
  solved for a free face and free-sliding edges. The edge forces are the first
  Piola-Kirchhoff stress ``P = tau F^-T`` times the edges' initial areas.

The sheets lie along the axis that ``shear_plane`` names ``s`` in shear, and across the fibres
in the sheet's x-z plane in a biaxial test (their normal along its thickness y). A material whose
fibres are turned (:func:`~cell.diagnosis.specimen.solve.fibre_turn_deg`, the cause
``fibre_direction``: a specimen cut at an angle to its fibres) has both turned by that angle about
the sheets' normal, the fibres towards the sheets, in every test. A transversely
isotropic material (``sheet_over_normal`` 1) makes the sheets and their normal alike, so its
shear modes pair up (``fs`` and ``fn``, ``sf`` and ``nf``, ``sn`` and ``ns`` give the same
forces); an orthotropic one parts them.

Example:
    >>> from cell.measure.shearbiaxial import ShearTest
    >>> from cell.measure.specimens import Specimen
    >>> from cell.tissue.material import MassSpringMaterial
    >>> t = np.linspace(0.0, 1.0, 5)
    >>> test = ShearTest("fs", "fs", t, 1e-4 * t, 0.0 * t)
    >>> run = simulate_shear(test, Specimen("cube", (0.01,) * 3), MassSpringMaterial.isotropic(1e4))
    >>> sorted(run.force_n), run.force_n["force_N"].shape
    (['force_N', 'normal_force_N'], (5,))
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from cell.diagnosis.specimen.solve import (
    SpecimenLattice,
    fibre_direction,
    fibre_turn_deg,
    sheet_direction,
    solve_path,
    turned,
)
from cell.measure.shearbiaxial import BiaxialTest, ShearTest
from cell.measure.specimens import MeasurementSet, Specimen
from cell.tissue.material import MassSpringMaterial

# F's components in a path and in the kernel's output: xx, yy, zz, xz.
_XX, _YY, _ZZ, _XZ = range(4)
#: A biaxial test's free components: the thickness and the in-plane shear.
_BIAXIAL_FREE = (_YY, _XZ)


@dataclass(frozen=True, eq=False)
class SimulatedForces:
    """The simulated forces of one shear or biaxial test.

    Attributes:
        test_id: the measured test's id.
        time_s: (n,) the test's sample times, s.
        force_n: each force by the column that measures it (``force_N``, ``normal_force_N``
            for shear; ``force_N``, ``force_x_N`` for biaxial), (n,) N, signed as measured.
        gradient: (n, 4) the deformation gradient's xx, yy, zz and xz at the samples.

    The module's example makes one.
    """

    test_id: str
    time_s: np.ndarray
    force_n: dict[str, np.ndarray]
    gradient: np.ndarray


def simulate_shear(test: ShearTest, specimen: Specimen, material: MassSpringMaterial,
                   lattice: SpecimenLattice | None = None) -> SimulatedForces:
    """Simulate the simple shear ``test`` on ``specimen`` (the test's own size where it has
    one) made of ``material`` (module docstring); ``lattice`` may be passed to reuse one.

    Raises:
        MaterialError: an anisotropy the lattice's springs cannot give.
        DivergenceError: no equilibrium at some sample (a spring collapsed).
    """
    lattice = SpecimenLattice.of(specimen) if lattice is None else lattice
    size = test.size_of(specimen)
    path = np.zeros((len(test.time_s), 4))
    path[:, _XZ] = test.gamma(size)
    fibre, sheet = turned(np.eye(3)[test.fibre_axis], np.eye(3)[test.sheet_axis],
                          fibre_turn_deg(material))
    tau, gradient = solve_path(lattice, lattice.law(material), test.test_id, test.time_s, path,
                               (), fibre, sheet, lattice.sheet_factor(material))
    area = size[0] * size[1]
    return SimulatedForces(test.test_id, test.time_s,
                           {"force_N": area * tau[:, _XZ], "normal_force_N": area * tau[:, _ZZ]},
                           gradient)


def simulate_biaxial(test: BiaxialTest, specimen: Specimen, material: MassSpringMaterial,
                     lattice: SpecimenLattice | None = None) -> SimulatedForces:
    """Simulate the biaxial ``test`` on ``specimen`` (the test's own size where it has one)
    made of ``material`` (module docstring); ``lattice`` may be passed to reuse one.

    Raises:
        MaterialError: an anisotropy the lattice's springs cannot give.
        DivergenceError: no equilibrium at some sample (a spring collapsed).
    """
    lattice = SpecimenLattice.of(specimen) if lattice is None else lattice
    size = test.size_of(specimen)
    strains = test.strains(size)
    path = np.zeros((len(test.time_s), 4))
    path[:, _ZZ], path[:, _XX] = strains[:, 0], strains[:, 1]
    angle = test.angle_deg + fibre_turn_deg(material)
    tau, gradient = solve_path(lattice, lattice.law(material), test.test_id, test.time_s, path,
                               _BIAXIAL_FREE, fibre_direction(angle), sheet_direction(angle),
                               lattice.sheet_factor(material))
    along_z, along_x = face_stress(tau, gradient)
    return SimulatedForces(test.test_id, test.time_s,
                           {"force_N": size[0] * size[1] * along_z,
                            "force_x_N": size[1] * size[2] * along_x}, gradient)


def face_stress(tau: np.ndarray, gradient: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The nominal normal stresses on the z faces and the x faces, Pa: ``P_zz`` and ``P_xx``
    of ``P = tau F^-T`` for the Kirchhoff stress ``tau`` and F (both (n, 4): xx, yy, zz, xz;
    F_zx = 0).

    Example:
        >>> tau, gradient = np.array([[2.0, 0.0, 3.0, 0.0]]), np.array([[2.0, 1.0, 1.5, 0.0]])
        >>> [v.tolist() for v in face_stress(tau, gradient)]
        [[2.0], [1.0]]
    """
    a, d, c = gradient[:, _XX], gradient[:, _ZZ], gradient[:, _XZ]
    return tau[:, _ZZ] / d, tau[:, _XX] / a - tau[:, _XZ] * c / (a * d)


def simulate_shear_biaxial(measurements: MeasurementSet, material: MassSpringMaterial
                           ) -> tuple[SimulatedForces, ...]:
    """Simulate every shear test, then every biaxial test, of a set on one lattice.

    Example:
        >>> from cell.measure.specimens import load_measurement_set
        >>> data = load_measurement_set("assets/measured/beef_round_example")
        >>> simulate_shear_biaxial(data, MassSpringMaterial.isotropic(6e3))
        ()
    """
    if measurements.specimen is None:
        return ()
    lattice = SpecimenLattice.of(measurements.specimen)
    runs: Sequence[SimulatedForces] = [
        *(simulate_shear(t, measurements.specimen, material, lattice)
          for t in measurements.shear_tests),
        *(simulate_biaxial(t, measurements.specimen, material, lattice)
          for t in measurements.biaxial_tests)]
    return tuple(runs)
