"""Episode variations: the keys ``reset(options=...)`` and the envs' ``options`` argument take.

Keys (every one optional; SI units):

- ``tissue``: a mapping of :class:`~cell.tissue.shape.MuscleShape` fields (a scenario's
  ``[tissue]`` table) but ``cell_size_m`` (the resolution is the env's constructor argument),
- ``material``: a material object or the path of a material TOML file,
- ``longitudinal_scale``, ``transverse_scale``: factors on a mass-spring material's modulus
  curves along and across the fibres (tension and compression), ``stiffening_scale`` a factor
  on their strain stiffening (every coefficient but the small-strain modulus, and an
  exponential law's exponent),
- ``fibre_direction``: the fibres' direction, world frame (a mass-spring material's), three
  numbers; ``fibre_yaw_rad`` turns it about the vertical, then ``fibre_pitch_rad`` tilts it
  up out of the table's plane,
- ``aponeurosis_stiffness_n_m``, ``tearing_stretch_m``, ``tearing_force_n``: the aponeurosis'
  stiffness and strength (``aponeurosis.stiffness_n_m``, ``.tearing_stretch_m``,
  ``.tearing_force_n``); ``force_scale``: a factor on the knife's cutting force (the
  seam's toughness; the measured curve's in the ``-v1`` envs),
- ``table_friction``, ``tissue_friction``: the contact friction coefficients of the table
  and of the muscles' surface (:class:`~cell.sim.scenario.SimulationParams`),
- ``force_noise_n``, ``torque_noise_nm``: the force/torque sensors' noise; ``force_bias_n``,
  ``torque_bias_nm``: their bias, three numbers each,
- ``perception_noise_sigma_at_1m_m``: the depth camera's noise at 1 m
  (``perception.noise_sigma_at_1m_m``),
- ``grasp_x_offset``, ``grasp_inset_offset_m``: offsets added to the pull plan's grasp point
  (fraction of the shank's length, and m in from its outer side),
- ``cut_speed_m_s``: the planned (and scripted) knife's speed; ``cut_table_clearance_m``: the
  planned cut's clearance above the table (:class:`~controllers.knife.CutPlan`), which a
  planner sets from the interface's depth it believes, so it differs from carcass to carcass.
- ``knife_pace``: the speed a scripted knife (``Pull``'s) cuts at, as a fraction of its
  plan's, in (0, 1]: a knife that the meat slows, so the plan's clock runs ahead of it (the
  env reads it; the scenario keeps the plan's speed).

An option that sets one scenario key has the key's name, with its section's name in front
where the key alone would not say what it is (``aponeurosis_stiffness_n_m``,
``cut_speed_m_s``). The previous release's names (:data:`RENAMED_OPTIONS`) still work for one
release, with a ``FutureWarning`` naming the new one.

Values are type-checked as a scenario file's are, and a bad one raises
:class:`~cell.errors.InputError` naming the key. Of several layers of options the last that
holds a key gives its value (the tissue merges field by field), so a factor or an offset applies
once.

Example:
    >>> from cell.sim.scenario import Scenario
    >>> scenario = apply_options(Scenario(), {"tissue": {"length_m": 0.4}, "force_noise_n": 0.1})
    >>> scenario.tissue.length_m, scenario.sensors.force_noise_n
    (0.4, 0.1)
    >>> apply_options(Scenario(), {"grasp_x_offset": 0.1}, {"grasp_x_offset": -0.1}
    ...               ).pull.grasp_x_fraction
    0.4
    >>> apply_options(Scenario(), {"force_noise_n": "high"})
    Traceback (most recent call last):
    cell.errors.InputError: force_noise_n: expected a number, got str 'high'
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from cell.config import updated
from cell.errors import InputError, MaterialError
from cell.sim.scenario import Scenario
from cell.tissue.curves import ModulusCurve
from cell.tissue.material import ContinuumMaterial, MassSpringMaterial
from cell.tissue.materialfile import load_material


def _tissue(scenario: Scenario, value: Any) -> Scenario:
    if isinstance(value, Mapping) and "cell_size_m" in value:
        raise InputError(None, "tissue.cell_size_m",
                         "not a tissue option: the resolution is the env's cell_size_m argument")
    return replace(scenario, tissue=updated(scenario.tissue, value, section="tissue"))


def _material(scenario: Scenario, value: Any) -> Scenario:
    if isinstance(value, str | Path):
        value = load_material(value)
    if not isinstance(value, ContinuumMaterial | MassSpringMaterial):
        raise InputError(None, "material", f"expected a material or a TOML path, got {value!r}")
    return replace(scenario, material=value)


def _mass_spring(scenario: Scenario, key: str) -> MassSpringMaterial:
    if not isinstance(scenario.material, MassSpringMaterial):
        raise MaterialError(None, key, "the continuum materials have no fibres")
    return scenario.material


def _fibre_direction(scenario: Scenario, value: Any) -> Scenario:
    material = _mass_spring(scenario, "fibre_direction")
    if isinstance(value, np.ndarray):  # as a Gymnasium user may give it
        value = value.tolist()
    return replace(scenario, material=updated(material, {"fibre_direction": value},
                                              error=MaterialError))


def _number(key: str, value: Any, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError(None, key, f"expected a finite number, got {value!r}")
    if positive and not value > 0:
        raise InputError(None, key, f"must be > 0, got {value}")
    return float(value)


def _turn_fibres(key: str) -> Callable[[Scenario, Any], Scenario]:
    """The option ``key``: the fibres turned by an angle about the vertical (yaw) or up out of
    the table's plane (pitch)."""
    def apply(scenario: Scenario, value: Any) -> Scenario:
        angle = _number(key, value)
        d = np.array(_mass_spring(scenario, key).fibre_direction)
        if key == "fibre_yaw_rad":
            c, s = math.cos(angle), math.sin(angle)
            turned = [c * d[0] - s * d[1], s * d[0] + c * d[1], d[2]]
        else:
            up = np.array([0.0, 0.0, 1.0]) - d[2] * d  # up, square to the fibres
            norm = np.linalg.norm(up)
            up = up / norm if norm > 1e-9 else np.array([1.0, 0.0, 0.0])
            turned = (math.cos(angle) * d + math.sin(angle) * up).tolist()
        return _fibre_direction(scenario, turned)
    return apply


def _scaled(curve: ModulusCurve | None, factor: float, stiffening: bool) -> ModulusCurve | None:
    if curve is None:
        return None
    if stiffening:
        return replace(curve, coefficients=(curve.coefficients[0],
                                            *(c * factor for c in curve.coefficients[1:])),
                       exponent=curve.exponent * factor)
    return replace(curve, coefficients=tuple(c * factor for c in curve.coefficients))


def _scale_moduli(key: str) -> Callable[[Scenario, Any], Scenario]:
    """The option ``key``: a factor on the longitudinal or transverse curves, or on both
    curves' stiffening."""
    names = {"longitudinal_scale": ("longitudinal", "longitudinal_compression"),
             "transverse_scale": ("transverse", "transverse_compression")}
    def apply(scenario: Scenario, value: Any) -> Scenario:
        factor = _number(key, value, positive=True)
        material = _mass_spring(scenario, key)
        stiffening = key == "stiffening_scale"
        curves = (names["longitudinal_scale"] + names["transverse_scale"] if stiffening
                  else names[key])
        try:
            material = replace(material, **{name: _scaled(getattr(material, name), factor,
                                                          stiffening) for name in curves})
        except InputError as exc:
            raise InputError(None, key, exc.message) from None
        return replace(scenario, material=material)
    return apply


def _field(part: str, name: str, key: str) -> Callable[[Scenario, Any], Scenario]:
    """The option ``key``: the field ``name`` of the scenario's ``part``."""
    def apply(scenario: Scenario, value: Any) -> Scenario:
        try:
            return replace(scenario, **{part: updated(getattr(scenario, part), {name: value})})
        except InputError as exc:
            raise InputError(None, key, exc.message) from None
    return apply


def _offset(part: str, name: str, key: str) -> Callable[[Scenario, Any], Scenario]:
    """The option ``key``: an offset added to the field ``name`` of the scenario's ``part``."""
    set_field = _field(part, name, key)
    def apply(scenario: Scenario, value: Any) -> Scenario:
        return set_field(scenario, getattr(getattr(scenario, part), name) + _number(key, value))
    return apply


def knife_pace(options: Mapping[str, Any]) -> float:
    """The option ``knife_pace`` of ``options`` (1 when absent), checked.

    Example:
        >>> knife_pace({"knife_pace": 0.8}), knife_pace({})
        (0.8, 1.0)
    """
    pace = _number("knife_pace", options.get("knife_pace", 1.0), positive=True)
    if pace > 1.0:
        raise InputError(None, "knife_pace", f"must be in (0, 1], got {pace}")
    return pace


def _check_pace(scenario: Scenario, value: Any) -> Scenario:
    knife_pace({"knife_pace": value})
    return scenario


# Applied in this order, so that factors, a fibre direction and its turns act on the material
# given beside them.
_OPTIONS: dict[str, Callable[[Scenario, Any], Scenario]] = {
    "tissue": _tissue,
    "material": _material,
    "longitudinal_scale": _scale_moduli("longitudinal_scale"),
    "transverse_scale": _scale_moduli("transverse_scale"),
    "stiffening_scale": _scale_moduli("stiffening_scale"),
    "fibre_direction": _fibre_direction,
    "fibre_yaw_rad": _turn_fibres("fibre_yaw_rad"),
    "fibre_pitch_rad": _turn_fibres("fibre_pitch_rad"),
    "aponeurosis_stiffness_n_m": _field("aponeurosis", "stiffness_n_m",
                                        "aponeurosis_stiffness_n_m"),
    "tearing_stretch_m": _field("aponeurosis", "tearing_stretch_m", "tearing_stretch_m"),
    "tearing_force_n": _field("aponeurosis", "tearing_force_n", "tearing_force_n"),
    "force_scale": _field("aponeurosis", "force_scale", "force_scale"),
    "table_friction": _field("simulation", "table_friction", "table_friction"),
    "tissue_friction": _field("simulation", "tissue_friction", "tissue_friction"),
    "force_noise_n": _field("sensors", "force_noise_n", "force_noise_n"),
    "torque_noise_nm": _field("sensors", "torque_noise_nm", "torque_noise_nm"),
    "force_bias_n": _field("sensors", "force_bias_n", "force_bias_n"),
    "torque_bias_nm": _field("sensors", "torque_bias_nm", "torque_bias_nm"),
    "perception_noise_sigma_at_1m_m": _field("perception", "noise_sigma_at_1m_m",
                                             "perception_noise_sigma_at_1m_m"),
    "grasp_x_offset": _offset("pull", "grasp_x_fraction", "grasp_x_offset"),
    "grasp_inset_offset_m": _offset("pull", "grasp_inset_m", "grasp_inset_offset_m"),
    "cut_speed_m_s": _field("cut", "speed_m_s", "cut_speed_m_s"),
    "cut_table_clearance_m": _field("cut", "table_clearance_m", "cut_table_clearance_m"),
    "knife_pace": _check_pace,
}
#: Every key an env's options may hold.
OPTION_KEYS = tuple(_OPTIONS)
#: The previous release's option names and their new ones (the scenario keys' names): the old
#: ones work, with a ``FutureWarning``, until the next release.
RENAMED_OPTIONS = {"shape": "tissue", "binding_stiffness_n_m": "aponeurosis_stiffness_n_m",
                   "camera_noise_at_1m_m": "perception_noise_sigma_at_1m_m"}


def renamed(options: Mapping[str, Any], source: str | None = None) -> dict[str, Any]:
    """``options`` with each old name of :data:`RENAMED_OPTIONS` replaced by its new one, a
    ``FutureWarning`` for each (``source``, a file, is named in it).

    Raises:
        InputError: an option given under both its names.

    Example:
        >>> import pytest
        >>> with pytest.warns(FutureWarning, match="use aponeurosis_stiffness_n_m"):
        ...     renamed({"binding_stiffness_n_m": 40.0})
        {'aponeurosis_stiffness_n_m': 40.0}
    """
    for old, new in RENAMED_OPTIONS.items():
        if old not in options:
            continue
        if new in options:
            raise InputError(source, old, f"given beside its new name {new}: give {new} alone")
        where = f"{source}: " if source else ""
        warnings.warn(f"{where}the env option {old} is renamed: use {new} (the old name goes "
                      "in the next release)", FutureWarning, stacklevel=3)
    # In the given order: a randomisation draws its keys in their order.
    return {RENAMED_OPTIONS.get(key, key): value for key, value in options.items()}


def merge_options(*layers: Mapping[str, Any]) -> dict[str, Any]:
    """One set of options from ``layers``, later ones over earlier ones key by key (the tissue
    field by field), old names renamed (:func:`renamed`).

    Example:
        >>> merge_options({"tissue": {"length_m": 0.4}, "force_noise_n": 0.1},
        ...               {"tissue": {"gap_m": 0.004}, "force_noise_n": 0.0})
        {'tissue': {'length_m': 0.4, 'gap_m': 0.004}, 'force_noise_n': 0.0}
    """
    merged: dict[str, Any] = {}
    for options in layers:
        for key, value in renamed(options).items():
            before = merged.get(key)
            if key == "tissue" and isinstance(before, Mapping) and isinstance(value, Mapping):
                value = {**before, **value}
            merged[key] = value
    return merged


def apply_options(scenario: Scenario, *layers: Mapping[str, Any]) -> Scenario:
    """``scenario`` with the variations in ``layers`` applied: merged by
    :func:`merge_options`, then key by key in the order of :data:`OPTION_KEYS`, so that a
    fibre direction from any layer turns the material from any layer.

    Values are checked as a scenario file's are (:func:`cell.config.updated`).

    Raises:
        InputError: an unknown key or a bad value; ``field`` names the key.
    """
    options = merge_options(*layers)
    for key in options:
        if key not in _OPTIONS:
            raise InputError(None, key, f"unknown env option (known: {', '.join(OPTION_KEYS)})")
    for key, apply in _OPTIONS.items():
        if key in options:
            scenario = apply(scenario, options[key])
    return scenario
