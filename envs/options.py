"""Episode variations: the keys ``reset(options=...)`` and the envs' ``options`` argument take.

Keys (every one optional; SI units):

- ``shape``: a mapping of :class:`~cell.tissue.geometry.MuscleShape` fields but ``cell_size_m`` (the
  resolution is the env's constructor argument),
- ``material``: a material object or the path of a material TOML file,
- ``fibre_direction``: the fibres' direction, world frame (a mass-spring material's),
- ``binding_stiffness_n_m``, ``tearing_stretch_m``: the aponeurosis' strength,
- ``force_noise_n``, ``torque_noise_nm``: the force/torque sensors' noise.

Example:
    >>> apply_options(Scenario(), {"shape": {"length_m": 0.4}, "force_noise_n": 0.1})
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

from cell.errors import InputError, MaterialError
from cell.sim.scenario import Scenario
from cell.tissue.geometry import MuscleShape
from cell.tissue.material import ContinuumMaterial, MassSpringMaterial
from cell.tissue.materialfile import load_material


def _shape(scenario: Scenario, value: Any) -> Scenario:
    if not isinstance(value, Mapping):
        raise InputError(None, "shape", f"expected a mapping of MuscleShape fields, got {value!r}")
    known = {f.name for f in fields(MuscleShape)} - {"cell_size_m"}
    for key in value:
        if key not in known:
            raise InputError(None, f"shape.{key}",
                             f"not a shape option (known: {', '.join(sorted(known))}; the "
                             "resolution is the env's cell_size_m argument)")
    return replace(scenario, tissue=replace(scenario.tissue, **value))


def _material(scenario: Scenario, value: Any) -> Scenario:
    if isinstance(value, str | Path):
        value = load_material(value)
    if not isinstance(value, ContinuumMaterial | MassSpringMaterial):
        raise InputError(None, "material", f"expected a material or a TOML path, got {value!r}")
    return replace(scenario, material=value)


def _fibre_direction(scenario: Scenario, value: Any) -> Scenario:
    if not isinstance(scenario.material, MassSpringMaterial):
        raise MaterialError(None, "fibre_direction", "the continuum materials have no fibres")
    return replace(scenario, material=replace(scenario.material,
                                              fibre_direction=tuple(map(float, value))))


def _aponeurosis(key: str) -> Callable[[Scenario, Any], Scenario]:
    def apply(scenario: Scenario, value: Any) -> Scenario:
        return replace(scenario, aponeurosis=replace(scenario.aponeurosis,
                                                     **{key: float(value)}))
    return apply


def _sensors(key: str) -> Callable[[Scenario, Any], Scenario]:
    def apply(scenario: Scenario, value: Any) -> Scenario:
        return replace(scenario, sensors=replace(scenario.sensors, **{key: float(value)}))
    return apply


# Applied in this order, so that a fibre direction turns the material given beside it.
_OPTIONS: dict[str, Callable[[Scenario, Any], Scenario]] = {
    "shape": _shape,
    "material": _material,
    "fibre_direction": _fibre_direction,
    "binding_stiffness_n_m": _aponeurosis("stiffness_n_m"),
    "tearing_stretch_m": _aponeurosis("tearing_stretch_m"),
    "force_noise_n": _sensors("force_noise_n"),
    "torque_noise_nm": _sensors("torque_noise_nm"),
}
#: Every key an env's options may hold.
OPTION_KEYS = tuple(_OPTIONS)


def apply_options(scenario: Scenario, options: Mapping[str, Any]) -> Scenario:
    """``scenario`` with the variations in ``options`` applied.

    Raises:
        InputError: an unknown key or a bad value; ``field`` names the key.
    """
    for key in options:
        if key not in _OPTIONS:
            raise InputError(None, key,
                             f"unknown env option (known: {', '.join(OPTION_KEYS)})")
    for key, apply in _OPTIONS.items():
        if key in options:
            scenario = apply(scenario, options[key])
    return scenario
