"""Hidden-effect cut sets: cut tests made by the full simulation (:mod:`cell.cuttest.run`) of a
drawn cutting model, written in the measurement format, the truth returned and never written.

A set is a block of the material file's tissue on a board and a blade, and
:data:`TEST_COUNT` tests: press cuts at several speeds and depths and sawing cuts at several
strokes, each sinking from just above the block to its depth, then drawing back a little (the
faces drag while the blade moves back, the edge does not). The blade's sensor is sampled
irregularly (a jittered rate, dropped samples) and reads with noise; the edge's position with
a little noise too.

The truth is the cut baseline (a constant toughness, the cell's contacts, frictionless faces)
plus the hidden causes of the format's cut table, each with drawn magnitudes:

==========================  ====================================================================
``blade_friction``          the faces' friction coefficient at the default beef's face pressure
``slicing``                 ``slicing_efficiency``
``rate_dependent_cutting``  ``rate_exponent`` (either sign) at the reference speed 10 mm/s
``indentation_stiffness``   ``indentation_depth_m``
``layered_toughness``       one layer depth and the factor of the layer below it
``blade_force_offset``      a constant 3-vector added to the sensor's force
``edge_loading``            ``loading_depth_m``
``edge_friction``           ``edge_friction`` and ``edge_slip_m``
``wedge_friction``          ``face_modulus_pa`` (mu E, 20-120 kPa: beef's modulus range times
                            its friction, a drag of a few newtons on the set's blades)
==========================  ====================================================================

The two terms with a state along the path (``edge_loading``, ``edge_friction``) draw from a
second stream of the seed, ``wedge_friction`` from a third, so that the sets drawn before
they existed are unchanged.

The faces' friction coefficient is drawn about the default beef's (the published one of
muscle on bone) at the default beef's ``face_pressure_pa``, which the diagnosis divides its
fitted shear stress by, so that the fitted coefficient compares with the truth. The force
noise is low (a fraction of a percent of the peak, a good load cell's) for the faces' drag to
show, above all while the blade is drawn back.

The simulation runs on a finer mesh (:data:`GENERATOR_CELL_M`) than the cell's, and the
diagnosis fits a reduced model that has no mesh at all, so a bench does not check a model
against itself. The set's files say that they are synthetic and how they were made, and hold
nothing of the truth (compare :mod:`cell.synthetic.specimen` for the uniaxial sets).

Example:
    >>> import tempfile
    >>> from pathlib import Path
    >>> folder = Path(tempfile.mkdtemp()) / "set"
    >>> truth = write_hidden_cut_set(folder, seed=3, causes=("slicing",), tests=1,
    ...                              cell_size_m=0.012)
    >>> truth.causes, sorted(p.name for p in folder.iterdir())
    (('slicing',), ['specimen.toml', 'tests.csv'])
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from cell.cuttest.run import CutSimulation, simulate_cut
from cell.diagnosis.cut.causes import CUT_CAUSES, FACE_PRESSURE_PA
from cell.errors import MeasurementError
from cell.measure.cuts import Blade, Block, CutTest, cut_rows_csv
from cell.outputs import write_atomic
from cell.tissue.cutmodel import CuttingParams
from cell.tissue.material import MassSpringMaterial, default_meat

#: The generator's mesh cell, m: finer than the cell's muscles (0.025 m) and envs' (0.05 m).
GENERATOR_CELL_M = 0.008
#: Tests per set.
TEST_COUNT = 10
#: The blade's sensor's nominal sampling rate, Hz.
SAMPLE_RATE_HZ = 100.0
#: Standard deviation of the logged edge position's noise, m (a robot's or tester's
#: encoders). Differentiated at the sampling rate it gives the speeds' noise: 5 micrometres
#: gave 0.7 mm/s, a sixth of the slowest cut's speed, in the slice/push ratio.
POSITION_NOISE_M = 1e-6
#: Height above the block's top where every cut starts, m.
START_HEIGHT_M = 0.002
#: The example set ``assets/measured/beef_cut_example``: its seed and hidden causes, kept here,
#: outside the set's folder (:func:`write_cut_example`).
EXAMPLE_SEED = 2026
EXAMPLE_CAUSES = ("slicing", "blade_force_offset")
_SAWING_TESTS = 4
@dataclass(frozen=True)
class CutTruth:
    """The answer key of one hidden-effect cut set (never written into the set).

    Attributes:
        causes: the hidden causes, in the catalogue's order (none: the baseline alone).
        seed: the seed everything was drawn from.
        cutting: the cutting model the simulation ran.
        offset_n: the sensor's offset, N (zero without ``blade_force_offset``).
        noise_n: standard deviation of the force noise, N.
        cell_size_m: the simulation's mesh cell, m.
        wall_s: wall-clock time of the set's simulations, s.
    """

    causes: tuple[str, ...]
    seed: int
    cutting: CuttingParams
    offset_n: tuple[float, float, float]
    noise_n: float
    cell_size_m: float
    wall_s: float


@dataclass(frozen=True)
class _Plan:
    """One test's path: sink at ``speed`` to ``depth`` below the top, with a sawing stroke of
    ``amplitude`` and ``period`` along the edge (0 for a press cut), then draw back."""

    test_id: str
    speed_m_s: float
    depth_m: float
    amplitude_m: float
    period_s: float

    @property
    def duration_s(self) -> float:
        sink = (self.depth_m + START_HEIGHT_M) / self.speed_m_s
        return sink + self.back_m / self.speed_m_s

    @property
    def back_m(self) -> float:
        return 0.3 * self.depth_m

    def edge_m(self, time_s: np.ndarray, start: np.ndarray) -> np.ndarray:
        sink = (self.depth_m + START_HEIGHT_M) / self.speed_m_s
        height = np.where(time_s <= sink, -self.speed_m_s * time_s,
                          -(self.depth_m + START_HEIGHT_M) + self.speed_m_s * (time_s - sink))
        along = (self.amplitude_m * np.sin(2.0 * np.pi * time_s / self.period_s)
                 if self.amplitude_m else np.zeros_like(time_s))
        return start + np.stack([np.zeros_like(time_s), along, height], axis=1)


def _plans(rng: np.random.Generator, height_m: float, count: int) -> list[_Plan]:
    """Press cuts at speeds spread over a decade and two depths, and sawing cuts."""
    plans = []
    for k in range(count):
        sawing = k >= count - min(_SAWING_TESTS, count // 2)
        speed = float(np.exp(rng.uniform(np.log(0.004), np.log(0.03))))
        if not sawing:
            speed = 0.004 * 7.5 ** ((k % 4) / 3) * rng.uniform(0.9, 1.1)
        depth = height_m * (0.45 if k % 2 else 0.7) * rng.uniform(0.95, 1.05)
        amplitude = rng.uniform(0.005, 0.012) if sawing else 0.0
        period = rng.uniform(0.6, 1.5) if sawing else 1.0
        plans.append(_Plan(f"c{k:02d}", speed, depth, amplitude, period))
    return plans


def _sample_times(rng: np.random.Generator, duration_s: float) -> np.ndarray:
    """A jittered sampling at :data:`SAMPLE_RATE_HZ` with a few samples dropped."""
    period = 1.0 / SAMPLE_RATE_HZ
    nominal = np.arange(0.0, duration_s, period)
    jittered = nominal + rng.uniform(-0.2, 0.2, len(nominal)) * period
    jittered[0] = 0.0
    kept = rng.uniform(size=len(jittered)) > rng.uniform(0.02, 0.08)
    kept[0] = kept[-1] = True
    return np.sort(jittered[kept])


def _truth_cutting(rng: np.random.Generator, causes: Sequence[str], height_m: float,
                   seed: int) -> tuple[CuttingParams, np.ndarray]:
    """The drawn cutting model and sensor offset: the baseline's toughness always, then each
    cause's magnitudes (drawn whether hidden or not, so the other draws do not depend on
    which causes are hidden)."""
    toughness = float(np.exp(rng.uniform(np.log(400.0), np.log(1500.0))))
    friction = rng.uniform(0.2, 0.6)
    slicing = rng.uniform(0.5, 1.5)
    rate = rng.choice([-1.0, 1.0]) * rng.uniform(0.15, 0.4)
    indentation = rng.uniform(0.002, 0.006)
    layer_depth = height_m * rng.uniform(0.25, 0.5)
    layer_factor = rng.choice([rng.uniform(0.4, 0.7), rng.uniform(1.5, 2.5)])
    offset = rng.normal(0.0, 1.0, 3)
    offset *= rng.uniform(0.5, 2.0) / np.linalg.norm(offset)
    second = np.random.default_rng((seed, 1))
    loading = second.uniform(0.002, 0.006)
    edge_friction = second.uniform(0.3, 1.0)
    edge_slip = second.uniform(0.001, 0.004)
    face_modulus = float(np.exp(np.random.default_rng((seed, 2)).uniform(np.log(2e4),
                                                                         np.log(1.2e5))))
    hidden = set(causes)
    layered = "layered_toughness" in hidden
    cutting = CuttingParams(
        toughness_j_m2=toughness,
        face_friction=friction if "blade_friction" in hidden else 0.0,
        face_pressure_pa=FACE_PRESSURE_PA,
        slicing_efficiency=slicing if "slicing" in hidden else 0.0,
        reference_speed_m_s=0.01,
        rate_exponent=rate if "rate_dependent_cutting" in hidden else 0.0,
        indentation_depth_m=indentation if "indentation_stiffness" in hidden else 0.0,
        layer_depths_m=(layer_depth,) if layered else (),
        layer_factors=(1.0, layer_factor) if layered else (),
        loading_depth_m=loading if "edge_loading" in hidden else 0.0,
        edge_friction=edge_friction if "edge_friction" in hidden else 0.0,
        edge_slip_m=edge_slip,
        face_modulus_pa=face_modulus if "wedge_friction" in hidden else 0.0)
    return cutting, offset if "blade_force_offset" in hidden else np.zeros(3)


def _check_causes(causes: Sequence[str]) -> tuple[str, ...]:
    unknown = [c for c in causes if c not in CUT_CAUSES]
    if unknown or len(set(causes)) != len(causes):
        raise MeasurementError(None, "causes", f"must be distinct causes of {CUT_CAUSES}, got "
                               f"{list(causes)}")
    return tuple(c for c in CUT_CAUSES if c in causes)


def write_hidden_cut_set(folder: Path, seed: int, causes: Sequence[str] = (),
                         material: MassSpringMaterial | None = None, tests: int = TEST_COUNT,
                         cell_size_m: float = GENERATOR_CELL_M) -> CutTruth:
    """Draw a cut set from ``seed`` with ``causes`` hidden in it, simulate it, write
    ``specimen.toml`` and ``tests.csv`` in ``folder`` (created) and return its truth.

    ``material``: the block's elastic material (the default beef's by default; its own
    ``[cutting]`` table is replaced by the drawn one).

    Raises:
        MeasurementError: an unknown cause, or one twice.
        DivergenceError: a simulation blew up.
    """
    hidden = _check_causes(causes)
    rng = np.random.default_rng(seed)
    size = np.round([rng.uniform(0.05, 0.07), rng.uniform(0.03, 0.045),
                     rng.uniform(0.025, 0.035)], 3)
    block = Block(tuple(float(s) for s in size), (1.0, 0.0, 0.0))
    blade = Blade(0.12, float(np.round(rng.uniform(0.001, 0.002), 4)), (0.0, 1.0, 0.0),
                  (1.0, 0.0, 0.0), 20.0)
    plans = _plans(rng, block.top_z_m, tests)
    cutting, offset = _truth_cutting(rng, hidden, block.top_z_m, seed)
    material = replace(material or default_meat(), cutting=cutting)
    start = np.array([size[0] / 2, size[1] / 2, size[2] + START_HEIGHT_M])
    settings = CutSimulation(cell_size_m)
    runs, wall = [], 0.0
    for plan in plans:
        time_s = _sample_times(rng, plan.duration_s)
        edge = plan.edge_m(time_s, start)
        run = simulate_cut(time_s, edge, block, blade, material, cutting, settings)
        runs.append((plan, time_s, edge, run.force_n))
        wall += run.wall_s
    peak = max(float(np.abs(force).max()) for *_, force in runs)
    noise = rng.uniform(0.001, 0.004) * peak
    tests = []
    for plan, time_s, edge, force in runs:
        measured = force + offset + rng.normal(0.0, noise, force.shape)
        seen = edge + rng.normal(0.0, POSITION_NOISE_M, edge.shape)
        seen[0] = edge[0]
        tests.append(CutTest(plan.test_id, time_s, seen, measured))
    folder = Path(folder)
    write_atomic(folder / "specimen.toml", _specimen_toml(seed, block, blade, plans,
                                                          cell_size_m))
    write_atomic(folder / "tests.csv", cut_rows_csv(tests))
    return CutTruth(hidden, seed, cutting, tuple(float(v) for v in offset), float(noise),
                    cell_size_m, wall)


def write_cut_example(folder: Path) -> CutTruth:
    """Write the example cut set (``assets/measured/beef_cut_example``) into ``folder``: the
    default beef, :data:`EXAMPLE_SEED`, :data:`EXAMPLE_CAUSES` hidden."""
    return write_hidden_cut_set(folder, EXAMPLE_SEED, EXAMPLE_CAUSES)


def _specimen_toml(seed: int, block: Block, blade: Blade, plans: Sequence[_Plan],
                   cell_size_m: float) -> str:
    """``specimen.toml``: how the set was made (nothing of its truth), ``[block]``, ``[blade]``."""
    lines = [
        "# SYNTHETIC cut set: no tissue was cut. Made by the project's hidden-effect cut",
        f"# generator (cell.synthetic.cut.write_hidden_cut_set, seed {seed}): every test is the",
        "# full simulation of the block (the material's mass-spring model, implicit step,",
        f"# {cell_size_m * 1000:g} mm cells, split by the blade's plane) with a drawn cutting "
        "model, the blade",
        "# driven along the path below; the sensor sampled irregularly, with dropped samples",
        "# and noise. The truth is kept out of these files (the example set",
        "# assets/measured/beef_cut_example is cell.synthetic.cut.write_cut_example's).",
        "#",
        "# Tests (edge speed into the block, depth below the top face, sawing stroke):",
        *(f"#   {p.test_id}  {p.speed_m_s * 1000:5.1f} mm/s to {p.depth_m * 1000:4.1f} mm, "
          + (f"sawing +-{p.amplitude_m * 1000:.1f} mm every {p.period_s:.2f} s"
             if p.amplitude_m else "press") + f", back {p.back_m * 1000:.1f} mm"
          for p in plans),
        "", "[block]",
        f"size_m = [{', '.join(f'{s:.3f}' for s in block.size_m)}]",
        f"fibre_direction = [{', '.join(f'{v:.1f}' for v in block.fibre_direction or ())}]",
        "", "[blade]",
        f"edge_length_m = {blade.edge_length_m}",
        f"thickness_m = {blade.thickness_m}",
        f"edge_angle_deg = {blade.edge_angle_deg}",
        f"edge_radius_m = {blade.edge_radius_m}",
        f"edge_direction = [{', '.join(f'{v:.1f}' for v in blade.edge_direction)}]",
        f"blade_normal = [{', '.join(f'{v:.1f}' for v in blade.blade_normal)}]", ""]
    return "\n".join(lines)


def describe(truth: CutTruth) -> dict[str, Any]:
    """The truth as plain data (for a bench's record, never for the set's folder).

    Example:
        >>> truth = CutTruth((), 0, CuttingParams(800.0), (0.0, 0.0, 0.0), 0.1, 0.004, 1.0)
        >>> describe(truth)["toughness_j_m2"]
        800.0
    """
    cutting = truth.cutting
    return {"causes": list(truth.causes), "seed": truth.seed,
            "toughness_j_m2": cutting.toughness_j_m2, "face_friction": cutting.face_friction,
            "slicing_efficiency": cutting.slicing_efficiency,
            "rate_exponent": cutting.rate_exponent,
            "reference_speed_m_s": cutting.reference_speed_m_s,
            "indentation_depth_m": cutting.indentation_depth_m,
            "layer_depths_m": list(cutting.layer_depths_m),
            "layer_factors": list(cutting.layer_factors),
            "loading_depth_m": cutting.loading_depth_m, "edge_friction": cutting.edge_friction,
            "edge_slip_m": cutting.edge_slip_m,
            "offset_n": list(truth.offset_n), "noise_n": truth.noise_n,
            "cell_size_m": truth.cell_size_m}
