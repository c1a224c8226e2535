"""Tissue materials: parameters of the muscles' constitutive model, in SI units.

The continuum material drives MuJoCo's own flex elasticity (linear or Saint Venant-Kirchhoff
stretching of the tetrahedra, with optional von Mises plasticity).
"""

from __future__ import annotations

from dataclasses import dataclass

from cell.errors import MaterialError


@dataclass(frozen=True)
class ContinuumMaterial:
    """Isotropic elastic (optionally elasto-plastic) continuum for MuJoCo flex tetrahedra.

    Attributes:
        young_pa: Young's modulus, Pa. The paper's meat: 0.03 MPa.
        poisson: Poisson's ratio, in [0, 0.5).
        density_kg_m3: mass density, kg/m^3.
        damping_s: stiffness-proportional (Rayleigh) damping, s.
        yield_strain: von Mises yield strain; 0 disables plasticity.

    Example:
        >>> meat = ContinuumMaterial(young_pa=3e4, poisson=0.4)
    """

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
