"""Material files: a material as TOML, read (:func:`load_material`, or a scenario's
``[material]`` table through :func:`material_from_table`) and written back
(:func:`material_to_toml`), every fault a :class:`~cell.errors.MaterialError` naming the file
and the dotted key.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from cell.config import DENSITY_KG_M3, MODULUS_PA, from_table, read_toml
from cell.errors import MaterialError
from cell.tissue.curves import DEFAULT_R_MAX, DEFAULT_R_MIN, ModulusCurve
from cell.tissue.cutmodel import CuttingParams
from cell.tissue.material import ContinuumMaterial, MassSpringMaterial


@dataclass(frozen=True)
class _CurveTable:
    """A modulus curve as written in a material file: a constant or polynomial coefficients."""

    modulus_pa: float | None = None
    coefficients: tuple[float, float, float, float, float, float] | None = None
    r_min: float = DEFAULT_R_MIN
    r_max: float = DEFAULT_R_MAX
    exponent: float = 0.0

    def __post_init__(self) -> None:
        if (self.modulus_pa is None) == (self.coefficients is None):
            raise MaterialError(
                None, "modulus_pa", "give either modulus_pa = <Pa> or coefficients = [6 values]"
            )
        if self.modulus_pa is not None and not self.modulus_pa > 0:
            raise MaterialError(None, "modulus_pa", f"must be > 0, got {self.modulus_pa}")
        key = "modulus_pa" if self.coefficients is None else "coefficients"
        # Built here so that from_table names the file and key of a bad polynomial; a steep
        # exponential overflows to an infinite modulus, refused, not warned about.
        with np.errstate(over="ignore"):
            curve = self.curve()
        _check_stiffness(curve, key, "exponent" if self.exponent else key)

    def curve(self) -> ModulusCurve:
        if self.coefficients is None:
            return ModulusCurve.exponential(float(self.modulus_pa), self.exponent, self.r_min,
                                            self.r_max)
        return ModulusCurve(self.coefficients, self.r_min, self.r_max, self.exponent)


def _check_stiffness(curve: ModulusCurve, key: str, steepest_key: str) -> None:
    """Raise :class:`MaterialError` naming ``key`` (``steepest_key``) unless the curve's
    modulus at rest (at its stiffest) is plausible (:data:`cell.config.MODULUS_PA`)."""
    with np.errstate(over="ignore"):
        stiffest = float(np.max(curve.modulus_pa(np.linspace(curve.r_min, curve.r_max, 65))))
    MODULUS_PA.check(curve.small_strain_modulus_pa, None, key, MaterialError)
    MODULUS_PA.check(stiffest, None, steepest_key, MaterialError)


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
        sheet_direction = [0.0, 0.0, 1.0]   # optional, with sheet_over_normal (orthotropy)
        sheet_over_normal = 1.8
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
        [cutting]                  # optional: cell.tissue.cutmodel.CuttingParams
        toughness_j_m2 = 850.0

    Raises:
        MaterialError: naming the file and the dotted key at fault (unknown key, wrong type,
            missing or non-positive modulus, modulus not positive over its range, zero fibre,
            a small-strain modulus or density beyond the plausible ranges of
            :mod:`cell.config`).

    Example:
        >>> load_material("assets/materials/beef_default.toml").transverse.small_strain_modulus_pa
        16000.0
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
    cutting = _cutting(raw.pop("cutting", None), file, key("cutting"))
    if model == "continuum":
        continuum = from_table(ContinuumMaterial, raw, file=file, section=section,
                               error=MaterialError)
        MODULUS_PA.check(continuum.young_pa, file, key("young_pa"), MaterialError)
        DENSITY_KG_M3.check(continuum.density_kg_m3, file, key("density_kg_m3"), MaterialError)
        return replace(continuum, cutting=cutting)
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
    material = from_table(MassSpringMaterial, raw, file=file, section=section,
                          error=MaterialError)
    DENSITY_KG_M3.check(material.density_kg_m3, file, key("density_kg_m3"), MaterialError)
    return replace(material, cutting=cutting)


def _cutting(table: object, file: str | Path | None, section: str) -> CuttingParams | None:
    """A material file's optional ``[cutting]`` table (:class:`CuttingParams`)."""
    if table is None:
        return None
    if not isinstance(table, dict):
        raise MaterialError(file, section, f"expected a table, got {type(table).__name__}")
    return from_table(CuttingParams, table, file=file, section=section, error=MaterialError)


def material_to_toml(material: MassSpringMaterial | ContinuumMaterial, comment: str = "") -> str:
    """``material`` (either kind) as a material file that :func:`load_material` reads back
    unchanged, ``comment`` (lines) on top.

    Raises:
        MaterialError: a modulus that :func:`load_material` would refuse
            (:data:`cell.config.MODULUS_PA`, at rest or at its stiffest): such a material is
            not written.

    Example:
        >>> from cell.tissue.material import default_meat
        >>> text = material_to_toml(default_meat(), "beef")
        >>> text.splitlines()[:2]
        ['# beef', 'model = "mass_spring"']
        >>> material_to_toml(ContinuumMaterial(young_pa=2.0e4)).splitlines()[:3]
        ['model = "continuum"', 'law = "stvk"', 'young_pa = 20000.0']
    """
    lines = [f"# {line}".rstrip() for line in comment.splitlines()]
    if isinstance(material, ContinuumMaterial):
        MODULUS_PA.check(material.young_pa, None, "young_pa", MaterialError)
        lines += ['model = "continuum"', f'law = "{material.law}"'] + [
            f"{name} = {_number(getattr(material, name))}"
            for name in ("young_pa", "poisson", "density_kg_m3", "damping_s", "yield_strain")]
    else:
        lines += _mass_spring_lines(material)
    if material.cutting is not None:
        lines += ["", "[cutting]"]
        for item in fields(CuttingParams):
            value = getattr(material.cutting, item.name)
            text = _numbers(value) if isinstance(value, tuple) else _number(value)
            lines.append(f"{item.name} = {text}")
    return "\n".join(lines) + "\n"


def _number(value: float) -> str:
    return repr(float(value))


def _numbers(values: tuple[float, ...]) -> str:
    return "[" + ", ".join(_number(v) for v in values) + "]"


def _mass_spring_lines(material: MassSpringMaterial) -> list[str]:
    """A mass-spring material's keys and modulus-curve tables (checked as the reader does)."""
    for name in _CURVES + _COMPRESSION_CURVES:
        curve = getattr(material, name)
        if curve is not None:
            _check_stiffness(curve, name, name)
    lines = [
        'model = "mass_spring"',
        f"density_kg_m3 = {_number(material.density_kg_m3)}",
        f"damping_s = {_number(material.damping_s)}",
        f"fibre_direction = {_numbers(material.fibre_direction)}",
        f"relaxation_weights = {_numbers(material.relaxation_weights)}",
        f"relaxation_times_s = {_numbers(material.relaxation_times_s)}",
        f"relaxation_strain_slope = {_number(material.relaxation_strain_slope)}",
        f"relaxation_reference_strain = {_number(material.relaxation_reference_strain)}",
        f"yield_strain = {_number(material.yield_strain)}",
        f"hardening = {_number(material.hardening)}",
        f"geometric_compensation = {_number(material.geometric_compensation)}",
        f"oblique = {_number(material.oblique)}",
    ]
    if material.oblique_compression is not None:
        lines.append(f"oblique_compression = {_number(material.oblique_compression)}")
    if material.orthotropic:
        lines += [f"sheet_direction = {_numbers(material.sheet_direction)}",
                  f"sheet_over_normal = {_number(material.sheet_over_normal)}"]
    for name in _CURVES + _COMPRESSION_CURVES:
        curve: ModulusCurve | None = getattr(material, name)
        if curve is None:
            continue
        lines += ["", f"[{name}]", f"coefficients = {_numbers(curve.coefficients)}",
                  f"r_min = {_number(curve.r_min)}", f"r_max = {_number(curve.r_max)}",
                  f"exponent = {_number(curve.exponent)}"]
    return lines
