"""Synthetic shear, biaxial and mixed sets that hide one cause of the specimen catalogue (or
nothing): the answer key of the diagnosis on tests in several planes.

Each set is drawn from one seed: a near-cubic specimen, a baseline modulus E and the hidden
cause's magnitudes drawn as the uniaxial hidden-effect sets draw them
(:func:`cell.synthetic.truth.draw_magnitudes`; orthotropy, which uniaxial sets cannot show,
draws E_s / E_n from 1.5 to 2.7 or its inverse, log-uniform, either sign). A fibre turn
(``fibre_direction``: the fibres and sheets turned about the sheets' normal by 8 to 30 degrees,
either sign) shows only beside an anisotropy of the lattice in the fibres' and sheets' plane,
so it is hidden as a pair with ``orthotropy`` or ``anisotropy``
(:attr:`HiddenCause.beside`), never alone. The truth is the cell's own springs with those
causes
(:class:`~cell.diagnosis.specimen.causes.candidate.CandidateMaterial`, :data:`HIDDEN_CAUSES`
maps the magnitudes onto its parameters), simulated as the diagnosis
simulates (:mod:`cell.diagnosis.specimen.shearbiaxial`, :mod:`cell.diagnosis.specimen.solve`),
so the sets hold no model error; Gaussian noise of 1 % of each column's peak, and a hidden load
cell's offset on every force column. The protocols, each what a lab runs (ramps at a base rate
of 1/20 of the peak a second, a ramp ten times faster, ramp-and-hold relaxations to 300 s at
two strains, two load-unload cycles):

- ``shear``: the six simple shear modes (fs, fn, sf, sn, nf, ns) to gamma 0.2, and in fs a
  fast ramp, holds at gamma 0.1 and 0.25, and cycles to 0.2 (ten tests);
- ``biaxial``: stretch ratios 1:1, 1:0.75, 0.75:1, 1:0.5 and 0.5:1 to 10 %, the fibres along
  z, and equibiaxially a fast ramp, holds at 5 and 12 %, and cycles to 10 % (nine tests);
- ``mixed``: four shear modes (fs, fn, sf, sn) to gamma 0.2, biaxial 1:1 and 1:0.5 to 10 %,
  tension to 10 % along and across the fibres, compression to 15 % along them, a fast
  tension ramp, relaxation holds at 6 and 15 % and tension cycles to 10 % (thirteen tests).

What a kind cannot show (:data:`HIDDEN_CAUSES` gives each cause's kinds): a biaxial test
only stretches, so no tension-compression asymmetry (the thickness' springs shorten, but the
edge forces hardly feel them); and it loads the fibres and the sheets, never their normal (the
thickness), so E_s / E_n and El / Et give the same edge forces up to E: no orthotropy. Simple
shear shortens one diagonal as it stretches the other, so an asymmetry shows in its normal
force; the mixed kind has a compression test as labs run beside tension and shear. A turn
hides only in shear and mixed sets: a biaxial test's edge forces are the same for a turn
either way (a mirror of the specimen), so its sign is the shear tests'.

The files (``specimen.toml``, ``tests.csv``) hold no truth parameter; the diagnosis never
imports this module.

Example:
    >>> truth = write_plane_set(Path("out/plane-3"), seed=3, kind="mixed", hidden="orthotropy")
    >>> truth.effect, 1.5 <= max(truth.sheet_over_normal, 1 / truth.sheet_over_normal) <= 2.7
    ('orthotropy', True)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cell.diagnosis.specimen.causes import CAUSES, UNIAXIAL_CAUSES, CandidateMaterial
from cell.diagnosis.specimen.shearbiaxial import simulate_biaxial, simulate_shear
from cell.diagnosis.specimen.solve import SpecimenLattice, simulate_tests
from cell.errors import MeasurementError
from cell.measure.shearbiaxial import BiaxialTest, ShearTest
from cell.measure.specimens import MechanicalTest, Mode, Specimen
from cell.synthetic.specimen import ASPECT_SPREAD, DENSITY_KG_M3, write_set
from cell.synthetic.truth import draw_magnitudes

PLANE_KINDS: tuple[str, ...] = ("shear", "biaxial", "mixed")
#: Noise on every force column, as a fraction of the column's peak (standard deviation).
NOISE_FRACTION = 0.01
_HEADER = ("test_id,mode,angle_deg,time_s,displacement_m,force_N,shear_plane,normal_force_N,"
           "displacement_x_m,force_x_N")
_RAMP_S, _HOLD_S, _SAMPLES = 20.0, 300.0, 41


@dataclass(frozen=True)
class HiddenCause:
    """How a plane set hides one cause: the kinds that can show it, its truth parameters
    (:class:`~cell.diagnosis.specimen.causes.candidate.CandidateMaterial`'s, by name) from the
    drawn magnitudes, its own draw where the uniaxial sets do not draw it, and the causes it
    shows only beside (``beside``: hidden as a pair with each of them, never alone).

    Example:
        >>> HIDDEN_CAUSES["plasticity"].shape({"yield_strain": 0.03, "tangent_ratio": 0.2})
        {'yield_strain': 0.03, 'hardening': 0.2}
    """

    kinds: tuple[str, ...]
    shape: Callable[[dict[str, float]], dict[str, float]]
    draw: Callable[[np.random.Generator], dict[str, float]] | None = None
    beside: tuple[str, ...] = ()


def _relaxation(m: dict[str, float]) -> dict[str, float]:
    return {"relaxed_fraction": m["relaxed"], "relaxation_share_0": m["split"],
            "log_relaxation_time_0": math.log10(m["tau1_s"]),
            "log_relaxation_time_1": math.log10(m["tau2_s"])}


def _draw_orthotropy(rng: np.random.Generator) -> dict[str, float]:
    sign = float(rng.choice((-1.0, 1.0)))
    return {"sheet_over_normal": math.exp(sign * rng.uniform(math.log(1.5), math.log(2.7)))}


def _draw_turn(rng: np.random.Generator) -> dict[str, float]:
    return {"fibre_turn_deg": float(rng.choice((-1.0, 1.0)) * rng.uniform(8.0, 30.0))}


#: Every cause a plane set can hide (adding one is one entry here).
HIDDEN_CAUSES: dict[str, HiddenCause] = {
    "strain_stiffening": HiddenCause(PLANE_KINDS, lambda m: {
        "stiffening_exponent": m["stiffening"],
        "compression_stiffening_exponent": m["stiffening"]}),
    "anisotropy": HiddenCause(PLANE_KINDS, lambda m: {
        "log_el_over_et": math.log(m["ratio_l_t"]),
        "log_el_over_et_compressed": math.log(m["ratio_l_t"])}),
    "viscoelasticity": HiddenCause(PLANE_KINDS, _relaxation),
    "nonlinear_viscoelasticity": HiddenCause(PLANE_KINDS, lambda m: {
        **_relaxation(m), "relaxed_fraction_slope": m["relaxed_per_strain"]}),
    "tension_compression_asymmetry": HiddenCause(("shear", "mixed"), lambda m: {
        "log_compression": math.log(m["compression_ratio"])}),
    "plasticity": HiddenCause(PLANE_KINDS, lambda m: {
        "yield_strain": m["yield_strain"], "hardening": m["tangent_ratio"]}),
    "force_offset": HiddenCause(PLANE_KINDS, lambda m: {}),
    "orthotropy": HiddenCause(("shear", "mixed"), lambda m: {
        "log_sheet_over_normal": math.log(m["sheet_over_normal"])}, _draw_orthotropy),
    "fibre_direction": HiddenCause(("shear", "mixed"), lambda m: {
        "fibre_turn_deg": m["fibre_turn_deg"]}, _draw_turn, ("orthotropy", "anisotropy")),
}
#: What a set can hide, as ``write_plane_set`` takes it.
Hidden = str | tuple[str, ...] | None
HIDDEN: tuple[Hidden, ...] = (
    *(c for c, h in HIDDEN_CAUSES.items() if not h.beside), None,
    *((other, c) for c, h in HIDDEN_CAUSES.items() for other in h.beside))
"""What a plane set can hide: one cause, None, or a cause beside another (the pairs last,
so that a single's or none's seeds draw as before they came)."""


def hidden_causes(hidden: Hidden) -> tuple[str, ...]:
    """The causes ``hidden`` names, in catalogue order.

    Example:
        >>> hidden_causes(None), hidden_causes("plasticity")
        ((), ('plasticity',))
        >>> hidden_causes(("fibre_direction", "orthotropy"))
        ('orthotropy', 'fibre_direction')
    """
    causes = () if hidden is None else (hidden,) if isinstance(hidden, str) else hidden
    return tuple(sorted(causes, key=lambda c: CAUSES.index(c) if c in CAUSES else len(CAUSES)))


def shows(kind: str, hidden: Hidden) -> bool:
    """Whether a ``kind`` set can hide ``hidden`` (one of :data:`HIDDEN`, every cause shown).

    Example:
        >>> shows("biaxial", "orthotropy"), shows("shear", ("orthotropy", "fibre_direction"))
        (False, True)
    """
    causes = hidden_causes(hidden)
    return (causes in map(hidden_causes, HIDDEN)
            and all(kind in HIDDEN_CAUSES[c].kinds for c in causes))


@dataclass(frozen=True)
class PlaneTruth:
    """What a plane set hides.

    Attributes:
        seed: the set's seed.
        kind: its protocol (module docstring).
        causes: the hidden causes, in catalogue order (none, one, or a cause beside
            another: :data:`HIDDEN`).
        magnitudes: ``young_pa`` (the baseline's small-strain modulus E, Pa) and the causes'
            drawn magnitudes (:func:`cell.synthetic.truth.draw_magnitudes`).
        offset_n: the load cell's offset on every force column, N (0 without
            ``force_offset``).

    Example:
        >>> PlaneTruth(0, "shear", (), {"young_pa": 1e4}).effect is None
        True
    """

    seed: int
    kind: str
    causes: tuple[str, ...]
    magnitudes: dict[str, float]
    offset_n: float = 0.0

    @property
    def effect(self) -> str | None:
        """The hidden cause, the first of a pair (None for none)."""
        return self.causes[0] if self.causes else None

    @property
    def modulus_pa(self) -> float:
        """The baseline's small-strain modulus E, Pa."""
        return self.magnitudes["young_pa"]

    @property
    def sheet_over_normal(self) -> float:
        """E_s / E_n (1 unless orthotropy is hidden)."""
        return self.magnitudes.get("sheet_over_normal", 1.0)

    @property
    def fibre_turn_deg(self) -> float:
        """The fibres' turn from the declared axes, degrees (0 unless a turn is hidden)."""
        return self.magnitudes.get("fibre_turn_deg", 0.0)

    @property
    def model(self) -> CandidateMaterial:
        """The truth's springs: the baseline with the hidden causes."""
        return CandidateMaterial(self.causes)

    @property
    def shape(self) -> np.ndarray:
        """The truth's shape parameters, in :attr:`model`'s order."""
        values = {name: v for c in self.causes
                  for name, v in HIDDEN_CAUSES[c].shape(self.magnitudes).items()}
        return np.array([values[name] for name in self.model.parameter_names])

    def reported(self) -> dict[str, float]:
        """The truth's parameters as a diagnosis reports the fitted ones
        (:meth:`~cell.diagnosis.specimen.causes.candidate.CandidateMaterial.reported`), those
        its kind can show: a biaxial set only stretches, so not the springs' moduli or
        stiffening in compression."""
        reported = self.model.reported(self.shape, self.modulus_pa, self.offset_n)
        if self.kind == "biaxial":
            return {name: v for name, v in reported.items() if "compression" not in name}
        return reported


Tests = tuple[list[ShearTest], list[BiaxialTest], list[MechanicalTest]]
#: A test with its forces by column.
Run = tuple[ShearTest | BiaxialTest | MechanicalTest, dict[str, np.ndarray]]


def _histories() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The protocol's shapes: (time_s, displacement over the peak) of a ramp, a ramp ten
    times faster, a ramp in 2 s then a hold, and two load-unload cycles."""
    ramp = np.linspace(0.0, 1.0, _SAMPLES)
    hold = np.concatenate([np.linspace(0.0, 2.0, 11), 2.0 + np.geomspace(0.2, _HOLD_S, 30)])
    cycle = np.linspace(0.0, 2.0 * _RAMP_S, _SAMPLES)
    return {"ramp": (_RAMP_S * ramp, ramp), "fast": (0.1 * _RAMP_S * ramp, ramp),
            "hold": (hold, np.minimum(hold / 2.0, 1.0)),
            "cycles": (cycle, 1.0 - np.abs(1.0 - (cycle / (0.5 * _RAMP_S)) % 2.0))}


def _tests(kind: str, size_m: np.ndarray) -> Tests:
    """The protocol's tests (module docstring) with zero forces (the truth gives them)."""
    shape = _histories()
    height, width = float(size_m[2]), float(size_m[0])

    def shear(test_id: str, plane: str, history: str, gamma: float) -> ShearTest:
        time, path = shape[history]
        return ShearTest(test_id, plane, time, gamma * height * path, 0.0 * time, 0.0 * time)

    def biaxial(test_id: str, history: str, z: float, x: float) -> BiaxialTest:
        time, path = shape[history]
        return BiaxialTest(test_id, 0.0, time, z * height * path, x * width * path,
                           0.0 * time, 0.0 * time)

    def uniaxial(test_id: str, mode: Mode, angle: float, history: str, strain: float
                 ) -> MechanicalTest:
        time, path = shape[history]
        return MechanicalTest(test_id, mode, angle, time, strain * height * path, 0.0 * time)

    if kind == "shear":
        planes = ("fs", "fn", "sf", "sn", "nf", "ns")
        return ([*(shear(p, p, "ramp", 0.2) for p in planes), shear("fs-fast", "fs", "fast", 0.2),
                 shear("fs-hold1", "fs", "hold", 0.1), shear("fs-hold2", "fs", "hold", 0.25),
                 shear("fs-cycles", "fs", "cycles", 0.2)], [], [])
    if kind == "biaxial":
        ratios = ((1.0, 1.0), (1.0, 0.75), (0.75, 1.0), (1.0, 0.5), (0.5, 1.0))
        return ([], [*(biaxial(f"b{z:g}-{x:g}", "ramp", 0.1 * z, 0.1 * x) for z, x in ratios),
                     biaxial("b1-1-fast", "fast", 0.1, 0.1),
                     biaxial("b1-1-hold1", "hold", 0.05, 0.05),
                     biaxial("b1-1-hold2", "hold", 0.12, 0.12),
                     biaxial("b1-1-cycles", "cycles", 0.1, 0.1)], [])
    return ([shear(p, p, "ramp", 0.2) for p in ("fs", "fn", "sf", "sn")],
            [biaxial("b1-1", "ramp", 0.1, 0.1), biaxial("b1-0.5", "ramp", 0.1, 0.05)],
            [uniaxial("t00", "tension", 0.0, "ramp", 0.1),
             uniaxial("t90", "tension", 90.0, "ramp", 0.1),
             uniaxial("c00", "compression", 0.0, "ramp", -0.15),
             uniaxial("t00-fast", "tension", 0.0, "fast", 0.1),
             uniaxial("r00", "relaxation", 0.0, "hold", 0.06),
             uniaxial("r90", "relaxation", 90.0, "hold", 0.15),
             uniaxial("y00", "cyclic", 0.0, "cycles", 0.1)])


def _columns(tests: Tests, specimen: Specimen, truth: PlaneTruth) -> list[Run]:
    """Each test with its forces under the truth, noise-free, by column."""
    material = truth.model.material(truth.shape, truth.modulus_pa, DENSITY_KG_M3)
    lattice = SpecimenLattice.of(specimen)
    shear, biaxial, uniaxial = tests
    runs: list[Run] = [
        (t, simulate_shear(t, specimen, material, lattice).force_n) for t in shear]
    runs += [(t, simulate_biaxial(t, specimen, material, lattice).force_n) for t in biaxial]
    runs += [(t, {"force_N": run.force_n}) for t, run in
             zip(uniaxial, simulate_tests(uniaxial, specimen, material, lattice), strict=True)]
    return runs


def _rows(runs: list[Run], offset_n: float, rng: np.random.Generator) -> list[str]:
    """The ``tests.csv`` rows: every force column with the offset and noise."""
    rows = []
    for test, clean in runs:
        f = {name: force + offset_n
             + rng.normal(0.0, NOISE_FRACTION * float(np.abs(force).max()), len(force))
             for name, force in clean.items()}
        t, d = test.time_s, test.displacement_m
        if isinstance(test, ShearTest):
            rows += [f"{test.test_id},shear,,{t[i]:.3f},{d[i]:.9f},{f['force_N'][i]:.9f},"
                     f"{test.shear_plane},{f['normal_force_N'][i]:.9f},," for i in range(len(t))]
        elif isinstance(test, BiaxialTest):
            rows += [f"{test.test_id},biaxial,0,{t[i]:.3f},{d[i]:.9f},{f['force_N'][i]:.9f},,,"
                     f"{test.displacement_x_m[i]:.9f},{f['force_x_N'][i]:.9f}"
                     for i in range(len(t))]
        else:
            rows += [f"{test.test_id},{test.mode},{test.angle_deg:g},{t[i]:.3f},{d[i]:.9f},"
                     f"{f['force_N'][i]:.9f},,,," for i in range(len(t))]
    return rows


def write_plane_set(folder: Path, seed: int, kind: str, hidden: Hidden) -> PlaneTruth:
    """Draw a ``kind`` set (one of :data:`PLANE_KINDS`) from ``seed`` hiding ``hidden`` (one
    of :data:`HIDDEN`: a cause of :data:`HIDDEN_CAUSES`, None for none, or a pair such as
    ``("orthotropy", "fibre_direction")``), write it in ``folder`` (module docstring) and
    return its truth.

    Raises:
        MeasurementError: an unknown ``kind``, or causes that are unknown, that ``kind``
            cannot show, or that hide only beside another.
    """
    if kind not in PLANE_KINDS:
        raise MeasurementError(None, "kind", f"must be one of {PLANE_KINDS}, got {kind!r}")
    if not shows(kind, hidden):
        raise MeasurementError(None, "hidden", f"{kind} sets hide one of "
                               f"{[h for h in HIDDEN if shows(kind, h)]}, got {hidden!r}")
    causes = hidden_causes(hidden)
    key = [hidden_causes(h) for h in HIDDEN].index(causes)
    rng = np.random.default_rng([seed, PLANE_KINDS.index(kind), key])
    edge = rng.uniform(0.008, 0.012)
    size = edge * (1.0 + rng.uniform(-ASPECT_SPREAD, ASPECT_SPREAD, 3))
    magnitudes = draw_magnitudes(rng, tuple(c for c in causes if c in UNIAXIAL_CAUSES), 1.0)
    for cause in causes:
        if HIDDEN_CAUSES[cause].draw is not None:
            magnitudes.update(HIDDEN_CAUSES[cause].draw(rng))
    specimen = Specimen(f"plane-{kind}-{seed}", tuple(float(s) for s in size))
    truth = PlaneTruth(seed, kind, causes, magnitudes)
    runs = _columns(_tests(kind, size), specimen, truth)
    peak = max(float(np.abs(force).max()) for _, forces in runs for force in forces.values())
    truth = PlaneTruth(seed, kind, causes, magnitudes,
                       magnitudes.get("offset_fraction", 0.0) * peak)
    sizes = ", ".join(f"{s:.6f}" for s in size)
    write_set(folder, f'[specimen]\nname = "{specimen.name}"\nsize_m = [{sizes}]\n'
              f"density_kg_m3 = {DENSITY_KG_M3:.1f}\n",
              "\n".join([_HEADER, *_rows(runs, truth.offset_n, rng)]) + "\n")
    return truth
