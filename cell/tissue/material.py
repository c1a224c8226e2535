"""Tissue materials: parameters of the muscles' constitutive models, in SI units.

Two models:

- :class:`ContinuumMaterial` drives MuJoCo's own flex elasticity (isotropic linear or Saint
  Venant-Kirchhoff stretching of the tetrahedra, with optional von Mises plasticity).
- :class:`MassSpringMaterial` drives the paper's anisotropic non-linear mass-spring model
  (:mod:`cell.tissue.massspring`): a modulus along the fibres and one across them, each a polynomial
  of the stretch r (current over rest length of a spring).

The paper's values (Nabil et al. 2015): E = 0.03 MPa isotropic with D = 0.1 N s/m per spring and
rho = 1500 kg/m^3 for the round of beef (Fig. 8); El = 0.25 MPa along the fibres and Et = Er =
0.6 MPa across them for the transversely isotropic test cuboid (Fig. 10); Et = Er = 0.003 MPa
for the bending cylinder (Fig. 11). The defaults here keep the Fig. 8 modulus, isotropic 30 kPa,
which is stable at a 2 ms step on the default muscles under the explicit step of the springs
(the Fig. 10 moduli and finer meshes need a smaller step:
:meth:`~cell.tissue.massspring.MassSpringModel.stable_timestep_s`); the implicit step (the
default, :mod:`cell.tissue.implicit`) runs any of them at the scenario's step. Beef density
1060 kg/m^3.

The moduli are :class:`~cell.tissue.curves.ModulusCurve`; a material file is TOML with
``model = "continuum"`` or ``model = "mass_spring"`` and the keys of the matching dataclass
(:mod:`cell.tissue.materialfile`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property, lru_cache
from typing import Any, Literal

import numpy as np

from cell.config import require_non_negative, require_positive
from cell.errors import MaterialError
from cell.tissue.curves import ModulusCurve
from cell.tissue.cutmodel import CuttingParams, beef_cutting


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
        cutting: the material's resistance to a blade (the file's ``[cutting]`` table), or
            None for a material without one.

    Example:
        >>> meat = ContinuumMaterial(young_pa=3e4, poisson=0.4)
    """

    law: Literal["stvk", "neo_hookean"] = "stvk"
    young_pa: float = 3.0e4
    poisson: float = 0.4
    density_kg_m3: float = 1060.0
    damping_s: float = 2.0e-3
    yield_strain: float = 0.0
    cutting: CuttingParams | None = None

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


def _meat_modulus() -> ModulusCurve:
    return ModulusCurve.constant(3.0e4)


@lru_cache(maxsize=256)
def _unit_fibre(direction: Any) -> tuple[float, float, float]:
    """The fibre ``direction`` normalised."""
    fibre = np.asarray(direction, dtype=float)
    norm = float(np.linalg.norm(fibre)) if fibre.shape == (3,) else math.nan
    if not (math.isfinite(norm) and norm > 1e-12):
        raise MaterialError(None, "fibre_direction",
                            f"must be a finite non-zero 3-vector, got {direction!r}")
    return tuple((fibre / norm).tolist())


@lru_cache(maxsize=256)
def _across_fibres(direction: Any, fibre_direction: tuple[float, float, float],
                   orthotropic: bool) -> Any:
    """The sheet ``direction`` made orthogonal to the unit ``fibre_direction`` and normalised
    (``direction`` itself where it lies along the fibres and the material is not
    orthotropic)."""
    sheet = np.asarray(direction, dtype=float)
    if not (sheet.shape == (3,) and np.isfinite(sheet).all()):
        raise MaterialError(None, "sheet_direction",
                            f"must be a finite 3-vector, got {direction!r}")
    fibre = np.asarray(fibre_direction)
    across = sheet - (sheet @ fibre) * fibre
    norm = float(np.linalg.norm(across))
    if norm > 1e-9 * max(float(np.linalg.norm(sheet)), 1e-300):
        return tuple((across / norm).tolist())
    if orthotropic:
        raise MaterialError(None, "sheet_direction", "must be a non-zero vector not along "
                            f"the fibres, got {direction!r}")
    return direction


def _remembered_if_exact(function: Any, *args: Any) -> Any:
    """``function(*args)`` for one of the memoised frame functions above, remembered where
    every argument keys it exactly (a bool, or a tuple of floats without a negative zero,
    which equals and hashes as 0.0); worked out each time otherwise (a list, an array). A
    fit makes thousands of materials, all with the same few directions."""
    exact = all(type(a) is bool or (type(a) is tuple and all(
        type(v) is float and (v or math.copysign(1.0, v) > 0) for v in a)) for a in args)
    return function(*args) if exact else function.__wrapped__(*args)


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
            grows. Under the explicit step the dashpots shorten the stable step to about
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
        relaxation_strain_slope: c in the relaxing share ``1 + c (|x| - x_r)`` of a spring's
            elastic stress at strain x (dimensionless, per unit strain): the fraction that
            relaxes is ``sum g_k (1 + c (|x| - x_r))``, clipped to [0, 1] (non-linear
            viscoelasticity; 0 is quasi-linear, < 0 relaxes less at larger strain, as muscle in
            compression does).
        relaxation_reference_strain: x_r, the spring strain at which the fraction that relaxes
            is ``sum g_k`` (>= 0; 0 for the share ``1 + c |x|``). A fraction that grows with the
            strain from (near) none at small strains needs x_r > 0: ``sum g_k`` is positive.
        yield_strain: spring strain beyond which its rest length flows (permanent set); 0 for
            an elastic material.
        hardening: post-yield tangent over the elastic modulus, in [0, 1) (linear kinematic
            hardening of the spring's elastic strain).
        oblique: springs at 45 degrees to the fibres get ``1 + oblique`` times Eq. 10's modulus,
            blended as ``4 c**2 (1 - c**2)`` in the cosine c (> -1; 0 is the paper's Eq. 10).
            The third constant of a transversely isotropic material's stiffness against the
            load angle, which Eq. 10 alone fixes from El and Et.
        oblique_compression: the same factor while a spring is shorter than at rest (> -1);
            None for ``oblique`` (tissue's shear stiffness differs between tension and
            compression as its moduli do: muscle is strongly anisotropic in tension only).
        geometric_compensation: k in a spring's stress ``E x / (1 + k x)``: a lattice of
            springs stiffens geometrically (its uniaxial nominal secant is about E (1 + 0.28
            strain) with k = 0), and ``cell.tissue.packedlaw.LATTICE_STIFFENING`` (0.33) cancels
            that, so that the curves are the nominal stress-strain curves of a uniaxial test. In
            [0, 1); fitted materials carry it, older ones keep 0.
        cutting: the material's resistance to a blade (the file's ``[cutting]`` table,
            :class:`~cell.tissue.cutmodel.CuttingParams`), or None for a material without one.
        sheet_direction: unit vector along the sheets, across the fibres, in the world frame
            (made orthogonal to the fibres and normalised on construction); the sheets' normal
            completes the frame (fibre x sheet). Default z: with fibres along x, sheets in
            the x-z plane, their normal along y.
        sheet_over_normal: orthotropy, E_s / E_n: the small-strain modulus along the sheets
            over the one along their normal (> 0). ``transverse`` is their geometric mean; 1
            (the default) is the transversely isotropic material, exactly as before. Springs
            get ``1 + (k - 1) (u . s)**2`` times their modulus, k calibrated on the lattice
            (:mod:`cell.tissue.lattice`).

    Raises:
        MaterialError: ``density_kg_m3``, ``damping_s``, the relaxation,
            ``yield_strain`` or ``hardening`` out of range, ``fibre_direction`` zero or not
            finite, ``sheet_over_normal`` not positive and finite, ``sheet_direction`` zero,
            not finite or (for an orthotropic material) along the fibres; curve errors name
            the curve's own fields.

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
    relaxation_strain_slope: float = 0.0
    oblique_compression: float | None = None
    relaxation_reference_strain: float = 0.0
    cutting: CuttingParams | None = None
    sheet_direction: tuple[float, float, float] = (0.0, 0.0, 1.0)
    sheet_over_normal: float = 1.0

    def __post_init__(self) -> None:
        require_positive(self, "density_kg_m3", error=MaterialError)
        require_non_negative(self, "damping_s", "yield_strain", "hardening",
                             "geometric_compensation", "relaxation_reference_strain",
                             error=MaterialError)
        for name in ("hardening", "geometric_compensation"):
            if not getattr(self, name) < 1:
                raise MaterialError(None, name, f"must be < 1, got {getattr(self, name)}")
        for name in ("oblique", "oblique_compression"):
            value = getattr(self, name)
            if value is not None and not -1 < value < math.inf:
                raise MaterialError(None, name, f"must be > -1 and finite, got {value}")
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
        if not math.isfinite(self.relaxation_strain_slope):
            raise MaterialError(None, "relaxation_strain_slope",
                                f"must be finite, got {self.relaxation_strain_slope}")
        object.__setattr__(self, "fibre_direction",
                           _remembered_if_exact(_unit_fibre, self.fibre_direction))
        self._check_sheet()

    def _check_sheet(self) -> None:
        """Normalise the sheet direction and make it orthogonal to the fibres."""
        if not (math.isfinite(self.sheet_over_normal) and self.sheet_over_normal > 0):
            raise MaterialError(None, "sheet_over_normal",
                                f"must be > 0 and finite, got {self.sheet_over_normal}")
        object.__setattr__(self, "sheet_direction", _remembered_if_exact(
            _across_fibres, self.sheet_direction, self.fibre_direction, self.orthotropic))

    @property
    def orthotropic(self) -> bool:
        """Whether the sheets and their normal differ (``sheet_over_normal`` != 1).

        Example:
            >>> MassSpringMaterial(sheet_over_normal=2.0).orthotropic
            True
        """
        return self.sheet_over_normal != 1.0

    @property
    def symmetric(self) -> bool:
        """Whether compressed springs follow the tension curves and oblique factor.

        Example:
            >>> MassSpringMaterial(oblique_compression=0.5).symmetric
            False
        """
        return (self.longitudinal_compression is self.transverse_compression
                is self.oblique_compression is None)

    def in_compression(self) -> MassSpringMaterial:
        """This material with its compression curves and oblique factor as its own.

        Example:
            >>> MassSpringMaterial().in_compression() == MassSpringMaterial()
            True
        """
        return self if self.symmetric else self._compressed

    @cached_property
    def _compressed(self) -> MassSpringMaterial:
        """:meth:`in_compression` of an asymmetric material, made once: every spring law of it
        asks."""
        oblique = self.oblique if self.oblique_compression is None else self.oblique_compression
        return replace(self, longitudinal=self.longitudinal_compression or self.longitudinal,
                       transverse=self.transverse_compression or self.transverse,
                       longitudinal_compression=None, transverse_compression=None,
                       oblique=oblique, oblique_compression=None)

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
    recruitment: 1.48 E0 at 40% strain). Fibres along the muscles' length (x). The explicit
    step of its springs is stable up to about 2.5 ms on the default mesh; the implicit one
    (the default) at any step. Its cutting model is
    :func:`~cell.tissue.cutmodel.beef_cutting`. The paper's own anisotropic test values (Fig. 10)
    are El = 0.25 MPa, Et = Er = 0.6 MPa: ``MassSpringMaterial.transversely_isotropic``.

    Example:
        >>> default_meat().longitudinal.small_strain_modulus_pa
        24000.0
    """

    def stiffening(modulus_pa: float) -> ModulusCurve:
        return ModulusCurve((modulus_pa, 0.0, 3.0 * modulus_pa, 0.0, 0.0, 0.0), 0.6, 1.4)

    return MassSpringMaterial(longitudinal=stiffening(2.4e4), transverse=stiffening(1.6e4),
                              cutting=beef_cutting())
