"""Synthetic shear, biaxial and mixed sets that hide orthotropy (or nothing): the answer key of
the ``orthotropy`` cause (:mod:`cell.diagnosis.specimen.causes.orthotropy`).

Each set is drawn from one seed: a near-cubic specimen, a baseline modulus E (log-uniform,
5 to 50 kPa), and with ``hidden`` a sheet-over-normal ratio E_s / E_n of 1.5 to 2.7 or its
inverse (log-uniform in magnitude, either sign); with ``turned`` as well the specimen's fibres
(and sheets) turned about the sheets' normal by 8 to 30 degrees, either sign (the cause
``fibre_direction``; the turn shows only with the orthotropy). The forces are the cell's own
springs' (:mod:`cell.diagnosis.specimen.shearbiaxial`, :mod:`cell.diagnosis.specimen.solve`:
the forward model of the diagnosis, whose baseline the truth extends), with Gaussian noise of
1 % of each column's peak. The protocols:

- ``shear``: the six simple shear modes (fs, fn, sf, sn, nf, ns) to gamma 0.2;
- ``mixed``: four shear modes (fs, fn, sf, sn), equibiaxial and 1:0.5 and 0.5:1 biaxial
  stretches to 10 % with the fibres along z, and tension to 10 % along and across the fibres.

The files (``specimen.toml``, ``tests.csv``) hold no truth parameter; the diagnosis never
imports this module.

Example:
    >>> truth = write_plane_set(Path("out/plane-3"), seed=3, kind="mixed", hidden=True)
    >>> truth.effect, 1.5 <= max(truth.sheet_over_normal, 1 / truth.sheet_over_normal) <= 2.7
    ('orthotropy', True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cell.diagnosis.specimen.causes import CandidateMaterial
from cell.diagnosis.specimen.shearbiaxial import simulate_biaxial, simulate_shear
from cell.diagnosis.specimen.solve import SpecimenLattice, simulate_tests
from cell.errors import MeasurementError
from cell.measure.shearbiaxial import BiaxialTest, ShearTest
from cell.measure.specimens import MechanicalTest, Specimen
from cell.synthetic.specimen import ASPECT_SPREAD, DENSITY_KG_M3, write_set

PLANE_KINDS: tuple[str, ...] = ("shear", "mixed")
#: Noise on every force column, as a fraction of the column's peak (standard deviation).
NOISE_FRACTION = 0.01
_SAMPLES = 41
_HEADER = ("test_id,mode,angle_deg,time_s,displacement_m,force_N,shear_plane,normal_force_N,"
           "displacement_x_m,force_x_N")
_SHEAR_GAMMA = 0.2
_STRETCH_STRAIN = 0.1


@dataclass(frozen=True)
class PlaneTruth:
    """What a plane set hides.

    Attributes:
        seed: the set's seed.
        kind: its protocol (module docstring).
        modulus_pa: the baseline's small-strain modulus E, Pa.
        sheet_over_normal: E_s / E_n (1 when nothing is hidden).
        fibre_turn_deg: the fibres' turn from the declared axes, degrees (0: none).

    Example:
        >>> PlaneTruth(0, "shear", 1e4, 1.0).effect is None
        True
    """

    seed: int
    kind: str
    modulus_pa: float
    sheet_over_normal: float
    fibre_turn_deg: float = 0.0

    @property
    def effect(self) -> str | None:
        """``orthotropy`` when the sheets and their normal differ, else None."""
        return None if self.sheet_over_normal == 1.0 else "orthotropy"

    @property
    def causes(self) -> tuple[str, ...]:
        """Every hidden cause, in catalogue order."""
        turn = ("fibre_direction",) if self.fibre_turn_deg != 0.0 else ()
        return (*((self.effect,) if self.effect else ()), *turn)


def _tests(kind: str, time_s: np.ndarray, size_m: np.ndarray
           ) -> tuple[list[ShearTest], list[BiaxialTest], list[MechanicalTest]]:
    """The protocol's tests with zero forces (the forces come from the truth)."""
    zero = 0.0 * time_s
    ramp = time_s / time_s[-1]
    planes = ("fs", "fn", "sf", "sn", "nf", "ns") if kind == "shear" else ("fs", "fn", "sf", "sn")
    shear = [ShearTest(p, p, time_s, _SHEAR_GAMMA * size_m[2] * ramp, zero, zero)
             for p in planes]
    if kind == "shear":
        return shear, [], []
    z, x = _STRETCH_STRAIN * size_m[2] * ramp, _STRETCH_STRAIN * size_m[0] * ramp
    biaxial = [BiaxialTest(name, 0.0, time_s, z * a, x * b, zero, zero)
               for name, a, b in (("b1-1", 1.0, 1.0), ("b1-05", 1.0, 0.5), ("b05-1", 0.5, 1.0))]
    tension = [MechanicalTest(f"t{angle:02d}", "tension", float(angle), time_s, z, zero)
               for angle in (0, 90)]
    return shear, biaxial, tension


def _rows(tests: tuple[list[ShearTest], list[BiaxialTest], list[MechanicalTest]],
          specimen: Specimen, truth: CandidateMaterial, shape: np.ndarray, modulus_pa: float,
          rng: np.random.Generator) -> list[str]:
    """The ``tests.csv`` rows of the protocol under the truth, with noise."""
    material = truth.material(shape, modulus_pa, DENSITY_KG_M3)
    lattice = SpecimenLattice.of(specimen)
    shear, biaxial, tension = tests

    def noisy(force: np.ndarray) -> np.ndarray:
        return force + rng.normal(0.0, NOISE_FRACTION * float(np.abs(force).max()), len(force))

    rows = []
    for test in shear:
        run = simulate_shear(test, specimen, material, lattice)
        force, normal = noisy(run.force_n["force_N"]), noisy(run.force_n["normal_force_N"])
        rows += [f"{test.test_id},shear,,{t:.3f},{d:.9f},{f:.9f},{test.shear_plane},{n:.9f},,"
                 for t, d, f, n in zip(test.time_s, test.displacement_m, force, normal,
                                       strict=True)]
    for test in biaxial:
        run = simulate_biaxial(test, specimen, material, lattice)
        force, force_x = noisy(run.force_n["force_N"]), noisy(run.force_n["force_x_N"])
        rows += [f"{test.test_id},biaxial,0,{t:.3f},{d:.9f},{f:.9f},,,{dx:.9f},{fx:.9f}"
                 for t, d, f, dx, fx in zip(test.time_s, test.displacement_m, force,
                                            test.displacement_x_m, force_x, strict=True)]
    for test, run in zip(tension, simulate_tests(tension, specimen, material, lattice),
                         strict=True):
        rows += [f"{test.test_id},tension,{test.angle_deg:g},{t:.3f},{d:.9f},{f:.9f},,,,"
                 for t, d, f in zip(test.time_s, test.displacement_m, noisy(run.force_n),
                                    strict=True)]
    return rows


def write_plane_set(folder: Path, seed: int, kind: str, hidden: bool,
                    turned: bool = False) -> PlaneTruth:
    """Draw a ``kind`` set (one of :data:`PLANE_KINDS`) from ``seed``, orthotropy ``hidden``
    or not (and ``turned`` fibres with it), write it in ``folder`` (module docstring) and
    return its truth.

    Raises:
        MeasurementError: an unknown ``kind``, or ``turned`` without ``hidden``.
    """
    if kind not in PLANE_KINDS:
        raise MeasurementError(None, "kind", f"must be one of {PLANE_KINDS}, got {kind!r}")
    if turned and not hidden:
        raise MeasurementError(None, "turned", "a fibre turn shows only with the orthotropy")
    rng = np.random.default_rng([seed, PLANE_KINDS.index(kind), int(hidden) + int(turned)])
    edge = rng.uniform(0.008, 0.012)
    size = edge * (1.0 + rng.uniform(-ASPECT_SPREAD, ASPECT_SPREAD, 3))
    modulus = float(math.exp(rng.uniform(math.log(5e3), math.log(5e4))))
    log_ratio = (float(rng.choice((-1.0, 1.0)) * rng.uniform(math.log(1.5), math.log(2.7)))
                 if hidden else 0.0)
    turn = float(rng.choice((-1.0, 1.0)) * rng.uniform(8.0, 30.0)) if turned else 0.0
    specimen = Specimen(f"plane-{kind}-{seed}", tuple(float(s) for s in size))
    truth = CandidateMaterial(("orthotropy", "fibre_direction"))
    time_s = np.linspace(0.0, 20.0, _SAMPLES)
    rows = _rows(_tests(kind, time_s, size), specimen, truth, np.array([log_ratio, turn]),
                 modulus, rng)
    sizes = ", ".join(f"{s:.6f}" for s in size)
    write_set(folder, f'[specimen]\nname = "{specimen.name}"\nsize_m = [{sizes}]\n'
              f"density_kg_m3 = {DENSITY_KG_M3:.1f}\n", "\n".join([_HEADER, *rows]) + "\n")
    return PlaneTruth(seed, kind, modulus, math.exp(log_ratio), turn)
