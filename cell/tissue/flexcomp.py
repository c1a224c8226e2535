"""A muscle or a specimen as an MJCF ``flexcomp``: the one MuJoCo element MjSpec cannot build
from arrays, so every tetrahedral soft body of the project is written through here."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from cell.tissue.material import ContinuumMaterial, MassSpringMaterial


def elasticity_xml(material: ContinuumMaterial | MassSpringMaterial) -> str:
    """The flexcomp's own elasticity: MuJoCo's continuum for a continuum material; none for a
    mass-spring material (its springs come from :class:`cell.tissue.massspring.MassSpringModel`),
    with a vanishing edge damping that tells MuJoCo the flex is meant to be soft."""
    if isinstance(material, MassSpringMaterial):
        return '<edge damping="1e-9"/>'
    plastic = f' yield="{material.yield_strain}"' if material.yield_strain > 0 else ""
    return (f'<elasticity young="{material.young_pa}" poisson="{material.poisson}" '
            f'damping="{material.damping_s}"{plastic}/>')


def flexcomp_xml(name: str, points_m: np.ndarray, tets: np.ndarray,
                 material: ContinuumMaterial | MassSpringMaterial, mass_kg: float, *,
                 radius_m: float, contact: str = "", pins: Sequence[int] = (),
                 rgba: str | None = None) -> str:
    """A ``flexcomp type="direct" dim="3"``: ``points_m`` (N, 3) in the parent body's frame,
    ``tets`` (M, 4), total ``mass_kg``, collision ``radius_m``, the attributes of its
    ``<contact>`` element, and the vertices pinned to the parent body.

    Example:
        >>> from cell.tissue.material import default_meat
        >>> points = 0.01 * np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
        >>> flexcomp_xml("tet", points, np.array([[0, 1, 2, 3]]), default_meat(), 1e-3,
        ...              radius_m=1e-4)[:46]
        '<flexcomp name="tet" type="direct" dim="3" poi'
    """
    point = " ".join(f"{v:.9g}" for v in np.asarray(points_m, float).ravel())
    element = " ".join(str(i) for i in np.asarray(tets).ravel())
    colour = f' rgba="{rgba}"' if rgba else ""
    pin = f'<pin id="{" ".join(str(i) for i in pins)}"/>' if len(pins) else ""
    return (f'<flexcomp name="{name}" type="direct" dim="3" point="{point}" element="{element}" '
            f'mass="{mass_kg:.9g}" radius="{radius_m}"{colour}>{elasticity_xml(material)}'
            f'<contact {contact}/>{pin}</flexcomp>')


def set_continuum_law(spec: mujoco.MjSpec, material: ContinuumMaterial | MassSpringMaterial
                      ) -> None:
    """Switch the spec's flexes to MuJoCo's stable neo-Hookean law when the material asks for
    it: the setting exists in MjSpec only, with no MJCF attribute."""
    if isinstance(material, ContinuumMaterial) and material.law == "neo_hookean":
        for flex in spec.flexes:
            flex.elastic3d = 1
