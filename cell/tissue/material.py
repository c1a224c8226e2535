"""Tissue materials: parameters of the muscles' constitutive models, in SI units.

Two models:

- :class:`ContinuumMaterial` drives MuJoCo's own flex elasticity (isotropic linear or Saint
  Venant-Kirchhoff stretching of the tetrahedra, with optional von Mises plasticity).
- :class:`MassSpringMaterial` drives the paper's anisotropic non-linear mass-spring model
  (:mod:`cell.tissue.massspring`): a modulus along the fibres and one across them, each a polynomial
  of the stretch r (current over rest length of a spring).

The paper's values (Nabil et al. 2015): E = 0.03 MPa isotropic with D = 0.1 N s/m per spring and
rho = 1500 kg/m^3 for the round of beef (Fig. 8); El = 0.25 MPa along the fibres and
Et = Er = 0.6 MPa across them for the transversely isotropic test cuboid (Fig. 10); Et = Er =
0.003 MPa for the bending cylinder (Fig. 11). The defaults here keep the Fig. 8 modulus, isotropic
30 kPa, which is stable at a 2 ms step on the default 1235-node muscles (measured limit 2.3 ms;
the Fig. 10 moduli need 0.38 ms there, and 4712 nodes at 30 kPa need 1.2 ms), with a beef
density of 1060 kg/m^3.

A material file is TOML with ``model = "continuum"`` or ``model = "mass_spring"`` and the keys of
the matching dataclass; see :func:`load_material`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.polynomial import polynomial as P

from cell.config import from_table, read_toml, require_non_negative, require_positive
from cell.errors import MaterialError

_DEGREE = 5
# The positivity check evaluates the modulus here and at its critical points in the range.
_POSITIVITY_SAMPLES = 2049
_DEFAULT_R_MIN = 0.5
_DEFAULT_R_MAX = 1.5


@dataclass(frozen=True)
class ContinuumMaterial:
    """Isotropic elastic (optionally elasto-plastic) continuum for MuJoCo flex tetrahedra: the
    paper's tensor-mass family, computed by MuJoCo itself.

    Attributes:
        law: ``"stvk"`` (Saint Venant-Kirchhoff: Green strain, linear stress) or
            ``"neo_hookean"`` (MuJoCo's stable neo-Hookean, non-linear stress; it cannot be
            exported as MJCF).
        young_pa: Young's modulus, Pa. The paper's meat: 0.03 MPa.
        poisson: Poisson's ratio, in [0, 0.5).
        density_kg_m3: mass density, kg/m^3.
        damping_s: stiffness-proportional (Rayleigh) damping, s.
        yield_strain: von Mises yield strain; 0 disables plasticity.

    Example:
        >>> meat = ContinuumMaterial(young_pa=3e4, poisson=0.4)
    """

    law: Literal["stvk", "neo_hookean"] = "stvk"
    young_pa: float = 3.0e4
    poisson: float = 0.4
    density_kg_m3: float = 1060.0
    damping_s: float = 2.0e-3
    yield_strain: float = 0.0

    def __post_init__(self) -> None:
        if not self.young_pa > 0:
            raise MaterialError(None, "young_pa", f"must be > 0, got {self.young_pa}")
        if not 0 <= self.poisson < 0.5:
            raise MaterialError(None, "poisson", f"must be in [0, 0.5), got {self.poisson}")
        if not self.density_kg_m3 > 0:
            raise MaterialError(None, "density_kg_m3", f"must be > 0, got {self.density_kg_m3}")
        if not self.damping_s >= 0:
            raise MaterialError(None, "damping_s", f"must be >= 0, got {self.damping_s}")
        if not self.yield_strain >= 0:
            raise MaterialError(None, "yield_strain", f"must be >= 0, got {self.yield_strain}")


@dataclass(frozen=True)
class ModulusCurve:
    """Tangent modulus as a function of the stretch r: the paper's 5th-degree polynomial or an
    exponential law, clamped outside its range.

    The modulus is ``E(r) = sum_k coefficients[k] * (r - 1)**k`` Pa inside ``[r_min, r_max]`` and
    its value at the nearer bound outside; with an ``exponent`` b > 0 it is the exponential law
    ``E(r) = coefficients[0] * exp(b |r - 1|)`` (collagen recruitment, stiffening both ways),
    whose other coefficients must be 0. The nominal stress is its integral from the rest
    state, ``sigma(r) = int_1^r E`` Pa, so the curve of a measured stress-stretch test is
    recovered by :meth:`fit` and reproduced by :meth:`stress_pa`.

    Attributes:
        coefficients: six polynomial coefficients in Pa; ``coefficients[0]`` is the small-strain
            modulus.
        r_min: lowest stretch of the fitted range, in (0, 1].
        r_max: highest stretch of the fitted range, >= 1.
        exponent: b of the exponential law (dimensionless); 0 for the polynomial.

    Raises:
        MaterialError: ``coefficients`` (not six finite numbers, or the modulus is not > 0
            everywhere in the range, or higher coefficients with an exponent), ``r_min`` or
            ``r_max`` (range not around 1), ``exponent`` (negative or not finite).

    Example:
        >>> curve = ModulusCurve((3e4, 1e5, 0, 0, 0, 0), r_min=0.8, r_max=1.3)
        >>> round(float(curve.modulus_pa(1.1)), 6), float(curve.modulus_pa(2.0))
        (40000.0, 60000.0)
        >>> round(float(curve.stress_pa(1.1)), 6)
        3500.0
        >>> round(float(ModulusCurve.exponential(3e4, 10.0).modulus_pa(0.9)), 1)
        81548.5
    """

    coefficients: tuple[float, float, float, float, float, float]
    r_min: float = _DEFAULT_R_MIN
    r_max: float = _DEFAULT_R_MAX
    exponent: float = 0.0

    def __post_init__(self) -> None:
        coefficients = np.asarray(self.coefficients, dtype=float)
        if coefficients.shape != (_DEGREE + 1,) or not np.isfinite(coefficients).all():
            raise MaterialError(
                None, "coefficients", f"must be six finite numbers, got {self.coefficients!r}"
            )
        object.__setattr__(self, "coefficients", tuple(coefficients.tolist()))
        if not (0.0 < self.r_min <= 1.0):
            raise MaterialError(None, "r_min", f"must be in (0, 1], got {self.r_min}")
        if not (1.0 <= self.r_max < math.inf and self.r_max > self.r_min):
            raise MaterialError(None, "r_max", f"must be >= 1 and > r_min, got {self.r_max}")
        if not (0.0 <= self.exponent < math.inf):
            raise MaterialError(None, "exponent", f"must be finite and >= 0, got {self.exponent}")
        if self.exponent and any(coefficients[1:]):
            raise MaterialError(None, "coefficients",
                                "an exponential curve takes coefficients[0] only, the rest 0")
        lowest, where = self._minimum()
        if not lowest > 0.0:
            raise MaterialError(
                None,
                "coefficients",
                f"modulus must be > 0 over [{self.r_min}, {self.r_max}], "
                f"got {lowest:.4g} Pa at r = {where:.4g}",
            )

    def _candidates(self, samples: int) -> np.ndarray:
        """``samples`` points spanning the range and the modulus's critical points in it, in
        x = r - 1: the modulus's extremes over the range are among them."""
        lo, hi = self.r_min - 1.0, self.r_max - 1.0
        critical = P.polyroots(P.polyder(self.coefficients)) if any(self.coefficients[1:]) else []
        # The real part of a nearly real pair (a nearly double root) still finds the extreme.
        return np.concatenate([np.linspace(lo, hi, samples), np.clip(np.real(critical), lo, hi)])

    def _minimum(self) -> tuple[float, float]:
        """Lowest modulus in the range (Pa) and the stretch where it is."""
        x = self._candidates(_POSITIVITY_SAMPLES)
        values = self._modulus_inside(x)
        i = int(np.argmin(values))
        return float(values[i]), float(x[i] + 1.0)

    @classmethod
    def constant(
        cls, modulus_pa: float, r_min: float = _DEFAULT_R_MIN, r_max: float = _DEFAULT_R_MAX
    ) -> ModulusCurve:
        """A linear material: the same modulus (Pa) at every stretch.

        Example:
            >>> ModulusCurve.constant(3e4).coefficients
            (30000.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        """
        return cls((modulus_pa, 0.0, 0.0, 0.0, 0.0, 0.0), r_min, r_max)

    @classmethod
    def exponential(
        cls, modulus_pa: float, exponent: float, r_min: float = _DEFAULT_R_MIN,
        r_max: float = _DEFAULT_R_MAX,
    ) -> ModulusCurve:
        """The exponential law ``modulus_pa * exp(exponent * |r - 1|)`` (Pa).

        Example:
            >>> ModulusCurve.exponential(3e4, 8.0).exponent
            8.0
        """
        return cls((modulus_pa, 0.0, 0.0, 0.0, 0.0, 0.0), r_min, r_max, exponent)

    @classmethod
    def fit(cls, stretch: np.ndarray, stress_pa: np.ndarray) -> ModulusCurve:
        """Least-squares fit to a measured nominal stress-stretch curve.

        The stress is fitted as the integral of the modulus polynomial, which makes it zero at
        r = 1 (the model is unloaded at rest) and avoids differentiating noisy data. The range
        is the measured one, widened to contain r = 1.

        Args:
            stretch: (n,) stretches (current over initial length), n >= 6, at least six distinct.
            stress_pa: (n,) nominal stresses (force over initial area), Pa.

        Raises:
            MaterialError: ``stretch`` or ``stress_pa`` unusable, or ``coefficients`` when the
                fitted modulus is not positive over the range.

        Example:
            >>> r = np.linspace(0.8, 1.3, 30)
            >>> curve = ModulusCurve.fit(r, 3e4 * (r - 1) + 5e4 * (r - 1) ** 2)
            >>> [round(c) for c in curve.coefficients[:3]]
            [30000, 100000, 0]
        """
        r = np.asarray(stretch, dtype=float).ravel()
        sigma = np.asarray(stress_pa, dtype=float).ravel()
        if r.shape != sigma.shape:
            raise MaterialError(
                None, "stress_pa", f"has {sigma.size} values for {r.size} stretches"
            )
        if not (np.isfinite(r).all() and (r > 0).all()):
            raise MaterialError(None, "stretch", "must be finite and > 0")
        if not np.isfinite(sigma).all():
            raise MaterialError(None, "stress_pa", "must be finite")
        if np.unique(r).size < _DEGREE + 1:
            raise MaterialError(
                None, "stretch", f"needs at least {_DEGREE + 1} distinct values, got {r.size}"
            )
        x = r - 1.0
        # Scaling x to [-1, 1] keeps the Vandermonde columns of similar size.
        scale = float(np.abs(x).max())
        k = np.arange(_DEGREE + 1)
        design = P.polyvander(x / scale, _DEGREE + 1)[:, 1:] / (k + 1)
        scaled, *_ = np.linalg.lstsq(design, sigma / scale, rcond=None)
        coefficients = scaled / scale**k
        return cls(tuple(coefficients.tolist()), min(float(r.min()), 1.0), max(float(r.max()), 1.0))

    @property
    def small_strain_modulus_pa(self) -> float:
        """Modulus at rest, Pa."""
        return self.coefficients[0]

    def _modulus_inside(self, x: np.ndarray) -> np.ndarray:
        """The modulus law at x = r - 1, unclamped, Pa."""
        if self.exponent:
            return self.coefficients[0] * np.exp(self.exponent * np.abs(x))
        return P.polyval(x, self.coefficients)

    def modulus_pa(self, r: np.ndarray | float) -> np.ndarray:
        """Tangent modulus d sigma / d r at stretch ``r``, Pa (clamped outside the range)."""
        return self._modulus_inside(np.clip(np.asarray(r, dtype=float), self.r_min, self.r_max)
                                    - 1.0)

    def stress_pa(self, r: np.ndarray | float) -> np.ndarray:
        """Nominal stress at stretch ``r``, Pa: the modulus integrated from r = 1."""
        r = np.asarray(r, dtype=float)
        x = np.clip(r, self.r_min, self.r_max) - 1.0
        if self.exponent:
            inside = np.sign(x) * self.coefficients[0] * np.expm1(self.exponent * np.abs(x)) / (
                self.exponent)
        else:
            inside = P.polyval(x, self.stress_coefficients())
        return inside + self.modulus_pa(r) * (r - 1.0 - x)

    def stress_coefficients(self) -> np.ndarray:
        """(7,) polynomial coefficients of the stress in (r - 1) inside the range, Pa (the
        polynomial law's; an exponential curve has none)."""
        return np.concatenate([[0.0], np.asarray(self.coefficients) / np.arange(1, _DEGREE + 2)])

    def max_modulus_pa(self) -> float:
        """Largest modulus at any stretch, Pa (it is reached inside the range)."""
        return float(self._modulus_inside(self._candidates(2)).max())


def _meat_modulus() -> ModulusCurve:
    return ModulusCurve.constant(3.0e4)


@dataclass(frozen=True)
class MassSpringMaterial:
    """Transversely isotropic, non-linear material of the paper's mass-spring model.

    Attributes:
        longitudinal: modulus El along the fibres, Pa, as a function of the spring stretch.
        transverse: modulus Et = Er across the fibres, Pa.
        density_kg_m3: mass density, kg/m^3.
        damping_s: stiffness-proportional damping time, s: each spring's dashpot is this times
            its current stiffness (a Kelvin-Voigt viscosity of about ``damping_s * E`` Pa s).
            The paper's D = 0.1 N s/m per spring is ``D / K``: 6e-4 s for the median spring
            of the default 1235-node muscles at 30 kPa, 7e-5 s at 250 kPa, 9e-4 s with 4712
            nodes at 30 kPa. Scaling with the stiffness keeps the damping a material property,
            the same on any mesh, and keeps every mode's damping ratio as the non-linear modulus
            grows. The dashpots are explicit and shorten the stable step to about
            ``sqrt(tau**2 + h0**2) - tau`` (h0 the undamped one); the default 2e-4 s leaves the
            default muscles stable up to 2.3 ms at 30 kPa.
        fibre_direction: unit vector along the fibres in the world frame (normalised on
            construction); the muscles' length runs along x.
        longitudinal_compression: El while a spring is shorter than at rest (tension-
            compression asymmetry: muscle is strongly anisotropic in tension, weakly in
            compression); None for the tension curve.
        transverse_compression: Et while a spring is shorter than at rest; None for the
            tension curve.
        relaxation_weights: g_k of the quasi-linear viscoelastic relaxation function
            ``G(t) = 1 - sum g_k + sum g_k exp(-t / tau_k)`` acting on every spring's elastic
            force (the curves are the instantaneous response); each >= 0, their sum < 1.
        relaxation_times_s: tau_k, s, one per weight.
        yield_strain: spring strain beyond which its rest length flows (permanent set); 0 for
            an elastic material.
        hardening: post-yield tangent over the elastic modulus, in [0, 1) (linear kinematic
            hardening of the spring's elastic strain).
        oblique: springs at 45 degrees to the fibres get ``1 + oblique`` times Eq. 10's modulus,
            blended as ``4 c**2 (1 - c**2)`` in the cosine c (> -1; 0 is the paper's Eq. 10).
            The third constant of a transversely isotropic material's stiffness against the
            load angle, which Eq. 10 alone fixes from El and Et.
        geometric_compensation: k in a spring's stress ``E x / (1 + k x)``: a lattice of
            springs stiffens geometrically (its uniaxial nominal secant is about E (1 + 0.28
            strain) with k = 0), and ``cell.tissue.springlaw.LATTICE_STIFFENING`` (0.33) cancels
            that, so that the curves are the nominal stress-strain curves of a uniaxial test. In
            [0, 1); fitted materials carry it, older ones keep 0.

    Raises:
        MaterialError: ``density_kg_m3``, ``damping_s``, the relaxation,
            ``yield_strain`` or ``hardening`` out of range, ``fibre_direction`` zero or not
            finite; curve errors name the curve's own fields.

    Example:
        >>> paper = MassSpringMaterial.transversely_isotropic(0.25e6, 0.6e6)
        >>> paper.transverse.small_strain_modulus_pa
        600000.0
        >>> MassSpringMaterial(fibre_direction=(0.0, 0.0, 2.0)).fibre_direction
        (0.0, 0.0, 1.0)
    """

    longitudinal: ModulusCurve = field(default_factory=_meat_modulus)
    transverse: ModulusCurve = field(default_factory=_meat_modulus)
    density_kg_m3: float = 1060.0
    damping_s: float = 2.0e-4
    fibre_direction: tuple[float, float, float] = (1.0, 0.0, 0.0)
    longitudinal_compression: ModulusCurve | None = None
    transverse_compression: ModulusCurve | None = None
    relaxation_weights: tuple[float, ...] = ()
    relaxation_times_s: tuple[float, ...] = ()
    yield_strain: float = 0.0
    hardening: float = 0.0
    geometric_compensation: float = 0.0
    oblique: float = 0.0

    def __post_init__(self) -> None:
        require_positive(self, "density_kg_m3", error=MaterialError)
        require_non_negative(self, "damping_s", "yield_strain", "hardening",
                             "geometric_compensation", error=MaterialError)
        for name in ("hardening", "geometric_compensation"):
            if not getattr(self, name) < 1:
                raise MaterialError(None, name, f"must be < 1, got {getattr(self, name)}")
        if not -1 < self.oblique < math.inf:
            raise MaterialError(None, "oblique", f"must be > -1 and finite, got {self.oblique}")
        weights = np.asarray(self.relaxation_weights, dtype=float)
        times = np.asarray(self.relaxation_times_s, dtype=float)
        if weights.shape != times.shape:
            raise MaterialError(None, "relaxation_times_s",
                                f"needs one time per weight: {times.size} for {weights.size}")
        if not (np.isfinite(weights).all() and (weights >= 0).all() and weights.sum() < 1):
            raise MaterialError(None, "relaxation_weights",
                                f"must be >= 0 with a sum < 1, got {self.relaxation_weights!r}")
        if not (np.isfinite(times).all() and (times > 0).all()):
            raise MaterialError(None, "relaxation_times_s",
                                f"must be finite and > 0, got {self.relaxation_times_s!r}")
        fibre = np.asarray(self.fibre_direction, dtype=float)
        norm = float(np.linalg.norm(fibre)) if fibre.shape == (3,) else math.nan
        if not (math.isfinite(norm) and norm > 1e-12):
            raise MaterialError(
                None,
                "fibre_direction",
                f"must be a finite non-zero 3-vector, got {self.fibre_direction!r}",
            )
        object.__setattr__(self, "fibre_direction", tuple((fibre / norm).tolist()))

    def in_compression(self) -> MassSpringMaterial:
        """This material with its compression curves as its curves.

        Example:
            >>> MassSpringMaterial().in_compression() == MassSpringMaterial()
            True
        """
        return replace(self, longitudinal=self.longitudinal_compression or self.longitudinal,
                       transverse=self.transverse_compression or self.transverse,
                       longitudinal_compression=None, transverse_compression=None)

    @classmethod
    def isotropic(cls, young_pa: float, **fields: Any) -> MassSpringMaterial:
        """Linear isotropic springs: El = Et = ``young_pa`` (Pa); other fields as keywords.

        Example:
            >>> MassSpringMaterial.isotropic(3e4, damping_s=0.0).damping_s
            0.0
        """
        curve = ModulusCurve.constant(young_pa)
        return cls(longitudinal=curve, transverse=curve, **fields)

    @classmethod
    def transversely_isotropic(
        cls, el_pa: float, et_pa: float, **fields: Any
    ) -> MassSpringMaterial:
        """Linear springs with El = ``el_pa`` along the fibres and Et = Er = ``et_pa`` across.

        Example:
            >>> MassSpringMaterial.transversely_isotropic(2.5e5, 6e5).longitudinal.coefficients[0]
            250000.0
        """
        return cls(
            longitudinal=ModulusCurve.constant(el_pa),
            transverse=ModulusCurve.constant(et_pa),
            **fields,
        )


def default_meat() -> MassSpringMaterial:
    """The muscles' default material: non-linear, transversely isotropic beef.

    Small-strain moduli El = 24 kPa along the fibres and Et = 16 kPa across: the order of the
    paper's isotropic E = 0.03 MPa, stiffer along the fibres as muscle is in tension (Morrow et
    al. 2010), mildly so as it is in compression (1.84 vs 1.42 kPa at stretch 0.7, JMBBM 2023).
    Both stiffen with strain, E(r) = E0 (1 + 3 (r - 1)^2) over r in [0.6, 1.4] (collagen
    recruitment: 1.48 E0 at 40% strain). Fibres along the muscles' length (x). Stable at the
    default 2 ms step on the default mesh. The paper's own anisotropic test values (Fig. 10)
    are El = 0.25 MPa, Et = Er = 0.6 MPa: ``MassSpringMaterial.transversely_isotropic``.

    Example:
        >>> default_meat().longitudinal.small_strain_modulus_pa
        24000.0
    """

    def stiffening(modulus_pa: float) -> ModulusCurve:
        return ModulusCurve((modulus_pa, 0.0, 3.0 * modulus_pa, 0.0, 0.0, 0.0), 0.6, 1.4)

    return MassSpringMaterial(longitudinal=stiffening(2.4e4), transverse=stiffening(1.6e4))


@dataclass(frozen=True)
class _CurveTable:
    """A modulus curve as written in a material file: a constant or polynomial coefficients."""

    modulus_pa: float | None = None
    coefficients: tuple[float, float, float, float, float, float] | None = None
    r_min: float = _DEFAULT_R_MIN
    r_max: float = _DEFAULT_R_MAX
    exponent: float = 0.0

    def __post_init__(self) -> None:
        if (self.modulus_pa is None) == (self.coefficients is None):
            raise MaterialError(
                None, "modulus_pa", "give either modulus_pa = <Pa> or coefficients = [6 values]"
            )
        if self.modulus_pa is not None and not self.modulus_pa > 0:
            raise MaterialError(None, "modulus_pa", f"must be > 0, got {self.modulus_pa}")
        # Built here so that from_table names the file and key of a bad polynomial.
        self.curve()

    def curve(self) -> ModulusCurve:
        if self.coefficients is None:
            return ModulusCurve.exponential(float(self.modulus_pa), self.exponent, self.r_min,
                                            self.r_max)
        return ModulusCurve(self.coefficients, self.r_min, self.r_max, self.exponent)


_CURVES = ("longitudinal", "transverse")
_COMPRESSION_CURVES = ("longitudinal_compression", "transverse_compression")


def load_material(path: str | Path) -> ContinuumMaterial | MassSpringMaterial:
    """Read a material TOML file.

    The file names its ``model`` and gives the fields of :class:`ContinuumMaterial` or
    :class:`MassSpringMaterial`; missing fields take the defaults, except that a mass-spring
    file must give both curves, each as a table with ``modulus_pa`` (a constant) or
    ``coefficients`` (six, Pa) and optionally ``r_min``, ``r_max`` and ``exponent`` (the
    exponential law on ``modulus_pa``)::

        model = "mass_spring"
        damping_s = 2e-4
        fibre_direction = [1.0, 0.0, 0.0]
        relaxation_weights = [0.3, 0.2]
        relaxation_times_s = [1.0, 30.0]
        [longitudinal]
        coefficients = [2.5e5, 1e6, 0, 0, 0, 0]
        r_min = 0.8
        r_max = 1.3
        [transverse]
        modulus_pa = 6e5
        exponent = 8.0
        [transverse_compression]   # optional, as the two above
        modulus_pa = 3e5

    Raises:
        MaterialError: naming the file and the dotted key at fault (unknown key, wrong type,
            missing or non-positive modulus, modulus not positive over its range, zero fibre).

    Example:
        >>> load_material("beef.toml").transverse.small_strain_modulus_pa  # doctest: +SKIP
        600000.0
    """
    path = Path(path)
    return material_from_table(read_toml(path, MaterialError), file=path)


def material_from_table(table: dict[str, Any], *, file: str | Path | None = None,
                        section: str = "") -> ContinuumMaterial | MassSpringMaterial:
    """A material from a parsed TOML table (a material file's body, or a scenario's
    ``[material]`` table named ``section``), as :func:`load_material` describes."""

    def key(name: str) -> str:
        return f"{section}.{name}" if section else name

    raw = dict(table)
    model = raw.pop("model", None)
    if model == "continuum":
        return from_table(ContinuumMaterial, raw, file=file, section=section, error=MaterialError)
    if model != "mass_spring":
        raise MaterialError(file, key("model"),
                            f"must be 'continuum' or 'mass_spring', got {model!r}")
    for name in _CURVES + _COMPRESSION_CURVES:
        if name not in raw:
            if name in _COMPRESSION_CURVES:
                continue
            raise MaterialError(file, key(name), "missing table: give modulus_pa = <Pa> or "
                                "coefficients = [6 values]")
        if not isinstance(raw[name], dict):
            raise MaterialError(file, key(name),
                                f"expected a table, got {type(raw[name]).__name__}")
        curve = from_table(
            _CurveTable, raw[name], file=file, section=key(name), error=MaterialError
        ).curve()
        raw[name] = {
            "coefficients": list(curve.coefficients),
            "r_min": curve.r_min,
            "r_max": curve.r_max,
            "exponent": curve.exponent,
        }
    return from_table(MassSpringMaterial, raw, file=file, section=section, error=MaterialError)


def material_to_toml(material: MassSpringMaterial, comment: str = "") -> str:
    """``material`` as a material file that :func:`load_material` reads back unchanged,
    ``comment`` (lines) on top.

    Example:
        >>> text = material_to_toml(default_meat(), "beef")
        >>> text.splitlines()[:2]
        ['# beef', 'model = "mass_spring"']
    """

    def number(value: float) -> str:
        return repr(float(value))

    def numbers(values: tuple[float, ...]) -> str:
        return "[" + ", ".join(number(v) for v in values) + "]"

    lines = [f"# {line}".rstrip() for line in comment.splitlines()]
    lines += [
        'model = "mass_spring"',
        f"density_kg_m3 = {number(material.density_kg_m3)}",
        f"damping_s = {number(material.damping_s)}",
        f"fibre_direction = {numbers(material.fibre_direction)}",
        f"relaxation_weights = {numbers(material.relaxation_weights)}",
        f"relaxation_times_s = {numbers(material.relaxation_times_s)}",
        f"yield_strain = {number(material.yield_strain)}",
        f"hardening = {number(material.hardening)}",
        f"geometric_compensation = {number(material.geometric_compensation)}",
        f"oblique = {number(material.oblique)}",
    ]
    for name in _CURVES + _COMPRESSION_CURVES:
        curve: ModulusCurve | None = getattr(material, name)
        if curve is None:
            continue
        lines += ["", f"[{name}]", f"coefficients = {numbers(curve.coefficients)}",
                  f"r_min = {number(curve.r_min)}", f"r_max = {number(curve.r_max)}",
                  f"exponent = {number(curve.exponent)}"]
    return "\n".join(lines) + "\n"
