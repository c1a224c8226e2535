"""Write the synthetic example measurement set from its stated truth model.

No tissue was tested: every force comes from the truth model below, with seeded noise, so
that a diagnosis of the set can be checked against what is in it. Magnitudes follow
published muscle tests (DESIGN.md, "Published tissue numbers"); the files follow the
project's measured-data format (``specimen.toml``, ``tests.csv``).

Truth model, nominal stress P against nominal strain e, angle theta to the fibres:

- quasi-linear viscoelasticity (QLV), P(t) = g_inf Pe(e(t)) + sum_k g_k int exp(-(t-s)/tau_k)
  dPe(s), integrated exactly for Pe linear in time between points of a fine grid;
- an exponential elastic law, stiffening with strain, with its own exponent and moduli in
  tension and in compression;
- transversely isotropic moduli 1/A = cos^4/A_L + sin^4/A_T + cos^2 sin^2/A_S.

Every test is a displacement path (the machine's input), linear between its sample times.
The force is the truth along that path plus N(0, 1 mN); the written displacement is the
path plus N(0, 0.3 um), except the first sample of each test, which is exactly 0. One
generator, seeded once, draws the noise test by test in the order of ``TESTS``: force
noise, then displacement noise. The generator itself (test plans, QLV integral, noise,
writers) is the library's, :mod:`cell.measure.protocols`, :mod:`cell.synthetic.truth` and
:mod:`cell.synthetic.specimen`; this script holds the example's truth, tests and header.

Usage::

    PYTHONPATH=. python scripts/make_example_set.py assets/measured/beef_round_example
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from cell.measure.protocols import TestPlan, cyclic, ramp, relaxation, true_force_n
from cell.synthetic.specimen import Digits, Noise, csv_text, measure, specimen_toml, write_set
from cell.synthetic.truth import qlv_stress_pa

SEED = 20240607
SIZE_M = 0.010  # cube edge; the load axis is z
AREA_M2 = SIZE_M * SIZE_M
FORCE_NOISE_N = 1.0e-3
DISPLACEMENT_NOISE_M = 0.3e-6

# QLV reduced relaxation function G(t) = g_inf + sum_k g_k exp(-t / tau_k), G(0) = 1.
TAU_S = (0.5, 5.0, 50.0)
G_K = (0.30, 0.30, 0.235)
G_INF = 0.165
# Exponential elastic law: e >= 0: Pe = A_t / b_t (exp(b_t e) - 1); e < 0: Pe = -A_c / b_c
# (exp(-b_c e) - 1), so that the small-strain modulus is A in both.
B_TENSION = 12.0
B_COMPRESSION = 6.0
# Moduli (A_L along the fibres, A_T across, A_S shear term), Pa.
MODULI_TENSION_PA = (40.3e3, 8.95e3, 2.37e3)
MODULI_COMPRESSION_PA = (4.85e3, 3.75e3, 2.11e3)

# Substeps of the fine grid per sample interval, for the QLV integral.
SUBSTEPS = 50
DIGITS = Digits(time_s=3, displacement_m=7, force_n=5, size_m=3)


# Published magnitudes (1 %/s unless said): compression to -0.3 peaks at 1.84 kPa (c00) and
# 1.42 kPa (c90), ~1.6x at 10x the rate; a 300 s hold relaxes 53-73 %; tension to 0.15 peaks
# at 9.0, 1.6, 2.0 kPa at 0, 45, 90 degrees. The replicates at other amplitudes, angles and
# rates give every condition a sibling for leave-one-test-out errors.
TESTS: tuple[TestPlan, ...] = (
    ramp("t00", "tension", 0, 0.15, 0.01, 250),
    ramp("t45", "tension", 45, 0.15, 0.01, 250),
    ramp("t90", "tension", 90, 0.15, 0.01, 250),
    ramp("c00", "compression", 0, -0.30, 0.01, 250),
    ramp("c45", "compression", 45, -0.30, 0.01, 250),
    ramp("c90", "compression", 90, -0.30, 0.01, 250),
    ramp("c00-fast", "compression", 0, -0.30, 0.10, 250),
    relaxation("r00", 0, -0.30, 0.01, 300.0, 61, 190),
    relaxation("r90", 90, -0.30, 0.01, 300.0, 61, 190),
    cyclic("y00", 0, -0.20, 0.02, 3, 300),
    # Replicates.
    ramp("t00-10", "tension", 0, 0.10, 0.01, 150),
    ramp("t45-10", "tension", 45, 0.10, 0.01, 150),
    ramp("t90-10", "tension", 90, 0.10, 0.01, 150),
    ramp("c00-20", "compression", 0, -0.20, 0.01, 150),
    ramp("c45-20", "compression", 45, -0.20, 0.01, 150),
    ramp("c90-20", "compression", 90, -0.20, 0.01, 150),
    ramp("t00-fast", "tension", 0, 0.15, 0.10, 150),
    ramp("c90-fast", "compression", 90, -0.30, 0.10, 150),
    relaxation("r45", 45, -0.30, 0.01, 300.0, 41, 130),
    cyclic("y90", 90, -0.20, 0.02, 3, 200),
)


def modulus_pa(moduli: tuple[float, float, float], angle_deg: float) -> float:
    """Transversely isotropic modulus at ``angle_deg`` to the fibres."""
    along, across, shear = moduli
    c2 = np.cos(np.radians(angle_deg)) ** 2
    s2 = 1.0 - c2
    return float(1.0 / (c2 * c2 / along + s2 * s2 / across + c2 * s2 / shear))


def elastic_stress_pa(strain: np.ndarray, angle_deg: float) -> np.ndarray:
    """Instantaneous elastic nominal stress Pe(e): exponential, different in tension and
    compression."""
    a_t = modulus_pa(MODULI_TENSION_PA, angle_deg)
    a_c = modulus_pa(MODULI_COMPRESSION_PA, angle_deg)
    tension = a_t / B_TENSION * np.expm1(B_TENSION * np.maximum(strain, 0.0))
    compression = -a_c / B_COMPRESSION * np.expm1(-B_COMPRESSION * np.minimum(strain, 0.0))
    return tension + compression


def stress_pa(time_s: np.ndarray, strain: np.ndarray, angle_deg: float) -> np.ndarray:
    """The truth: QLV over the exponential, anisotropic elastic law, Pa."""
    return qlv_stress_pa(time_s, elastic_stress_pa(strain, angle_deg), G_INF,
                         tuple(zip(G_K, TAU_S, strict=True)))


def example_csv(tests: tuple[TestPlan, ...], seed: int = SEED) -> str:
    """The tests.csv text: the truth on a grid ``SUBSTEPS`` times finer than the samples (the
    machine drives the displacement linearly between them), plus seeded noise."""
    forces = [true_force_n(plan, stress_pa, AREA_M2, SUBSTEPS) for plan in tests]
    noise = Noise(FORCE_NOISE_N, DISPLACEMENT_NOISE_M)
    return csv_text(tests, measure(tests, forces, SIZE_M, noise, np.random.default_rng(seed)),
                     DIGITS)


def _kpa(moduli: tuple[float, float, float]) -> str:
    along, across, shear = (f"{a / 1e3:g}" for a in moduli)
    return f"A_L = {along} kPa, A_T = {across} kPa, A_S = {shear} kPa"


def header(tests: tuple[TestPlan, ...]) -> str:
    """The comment lines on top of specimen.toml: what the set is and how it was made."""
    width = max(len(plan.test_id) for plan in tests)
    listing = [f"#   {plan.test_id:<{width}} {plan.angle_deg:>2g} deg  {plan.description}, "
               f"{len(plan.time_s)} samples" for plan in tests]
    taus = ", ".join(f"{t:g}" for t in TAU_S)
    gs = ", ".join(f"{g:.3g}" for g in G_K)
    return "\n".join([
        "# SYNTHETIC measurement set: no tissue was tested. The forces come from a stated truth"
        " model",
        "# with seeded noise, so that a diagnosis of this set can be checked against what is in"
        " it.",
        "# Generator: scripts/make_example_set.py (run with this folder as its argument, it"
        " writes",
        "# both files again, identically).",
        "#",
        "# Magnitudes follow published muscle tests (DESIGN.md, \"Published tissue numbers\"):",
        "# - unconfined compression to stretch 0.7 at 1 %/s peaks at 1.84 kPa along the fibres"
        " (c00)",
        "#   and 1.42 kPa across them (c90);",
        "# - a 10x faster ramp raises that peak by about 60 % (c00-fast: 2.95 kPa);",
        "# - stress relaxes by 53 to 73 % over a 300 s hold (r00, r45, r90: 63 %);",
        "# - anisotropy is weak in compression and strong in tension (Morrow et al. 2010): at"
        " stretch",
        "#   1.15 and 1 %/s the tension peaks are 9.0 kPa along, 2.0 kPa across, 1.6 kPa at 45"
        " degrees.",
        "#",
        "# Tests (nominal strain, and its rate; every condition is tested twice or more,",
        "# at another amplitude, angle or rate, so that leave-one-test-out errors mean"
        " something):",
        *listing,
        "#",
        "# Truth model, nominal stress P against nominal strain e, angle theta to the fibres:",
        "#   quasi-linear viscoelasticity P(t) = g_inf Pe(e(t)) + sum_k g_k int exp(-(t - s)/tau_k)"
        " dPe(s)",
        f"#     tau = {taus} s; g = {gs}; g_inf = {G_INF:g} (rate dependence, relaxation);",
        "#   instantaneous elastic law, exponential (strain stiffening):",
        f"#     tension     e >= 0: Pe = A_t(theta) / {B_TENSION:g} * (exp({B_TENSION:g} e) - 1)",
        f"#     compression e <  0: Pe = -A_c(theta) / {B_COMPRESSION:g} *"
        f" (exp(-{B_COMPRESSION:g} e) - 1)",
        "#   transversely isotropic moduli 1/A = cos^4/A_L + sin^4/A_T + cos^2 sin^2/A_S"
        " (anisotropy):",
        f"#     tension     {_kpa(MODULI_TENSION_PA)}",
        f"#     compression {_kpa(MODULI_COMPRESSION_PA)} (tension-compression asymmetry)",
        "#   no plasticity, no load-cell offset; the displacement is linear between samples.",
        f"# Noise: force N(0, {FORCE_NOISE_N * 1e3:g} mN), displacement"
        f" N(0, {DISPLACEMENT_NOISE_M * 1e6:g} um), seed {SEED}; first displacement 0.",
        "# Effects present, for a diagnosis to find: strain_stiffening, anisotropy,"
        " viscoelasticity,",
        "# tension_compression_asymmetry. Absent: plasticity, force_offset.",
    ])


def main(argv: list[str] | None = None) -> None:
    """Write specimen.toml and tests.csv into the folder named on the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="the measurement set's folder")
    folder = parser.parse_args(argv).folder
    rig = {"machine": "uniaxial tester, platens bonded to the specimen (synthetic)",
           "load_cell_N": 10.0, "force_noise_N": FORCE_NOISE_N}
    write_set(folder, specimen_toml(header(TESTS), "beef-round-example (synthetic)",
                                    (SIZE_M,) * 3, rig, DIGITS), example_csv(TESTS))
    print(f"wrote {len(TESTS)} tests to {folder}")


if __name__ == "__main__":
    main()
