"""Episode variations: the keys ``reset(options=...)`` and the envs' ``options`` argument take.

Keys (every one optional; SI units):

- ``shape``: a mapping of :class:`~cell.tissue.geometry.MuscleShape` fields but ``cell_size_m`` (the
  resolution is the env's constructor argument),
- ``material``: a material object or the path of a material TOML file,
- ``fibre_direction``: the fibres' direction, world frame (a mass-spring material's), three
  numbers,
- ``binding_stiffness_n_m``, ``tearing_stretch_m``: the aponeurosis' strength,
- ``force_noise_n``, ``torque_noise_nm``: the force/torque sensors' noise.

Values are type-checked as a scenario file's are, and a bad one raises
:class:`~cell.errors.InputError` naming the key.

Example:
    >>> from cell.sim.scenario import Scenario
    >>> scenario = apply_options(Scenario(), {"shape": {"length_m": 0.4}, "force_noise_n": 0.1})
    >>> scenario.tissue.length_m, scenario.sensors.force_noise_n
    (0.4, 0.1)
    >>> apply_options(Scenario(), {"force_noise_n": "high"})
    Traceback (most recent call last):
    cell.errors.InputError: force_noise_n: expected a number, got str 'high'
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from cell.config import updated
from cell.errors import InputError, MaterialError
from cell.sim.scenario import Scenario
from cell.tissue.material import ContinuumMaterial, MassSpringMaterial
from cell.tissue.materialfile import load_material


def _shape(scenario: Scenario, value: Any) -> Scenario:
    if isinstance(value, Mapping) and "cell_size_m" in value:
        raise InputError(None, "shape.cell_size_m",
                         "not a shape option: the resolution is the env's cell_size_m argument")
    return replace(scenario, tissue=updated(scenario.tissue, value, section="shape"))


def _material(scenario: Scenario, value: Any) -> Scenario:
    if isinstance(value, str | Path):
        value = load_material(value)
    if not isinstance(value, ContinuumMaterial | MassSpringMaterial):
        raise InputError(None, "material", f"expected a material or a TOML path, got {value!r}")
    return replace(scenario, material=value)


def _fibre_direction(scenario: Scenario, value: Any) -> Scenario:
    if not isinstance(scenario.material, MassSpringMaterial):
        raise MaterialError(None, "fibre_direction", "the continuum materials have no fibres")
    if isinstance(value, np.ndarray):  # as a Gymnasium user may give it
        value = value.tolist()
    return replace(scenario, material=updated(scenario.material, {"fibre_direction": value},
                                              error=MaterialError))


def _field(part: str, name: str, key: str) -> Callable[[Scenario, Any], Scenario]:
    """The option ``key``: the field ``name`` of the scenario's ``part``."""
    def apply(scenario: Scenario, value: Any) -> Scenario:
        try:
            return replace(scenario, **{part: updated(getattr(scenario, part), {name: value})})
        except InputError as exc:
            raise InputError(None, key, exc.message) from None
    return apply


# Applied in this order, so that a fibre direction turns the material given beside it.
_OPTIONS: dict[str, Callable[[Scenario, Any], Scenario]] = {
    "shape": _shape,
    "material": _material,
    "fibre_direction": _fibre_direction,
    "binding_stiffness_n_m": _field("aponeurosis", "stiffness_n_m", "binding_stiffness_n_m"),
    "tearing_stretch_m": _field("aponeurosis", "tearing_stretch_m", "tearing_stretch_m"),
    "force_noise_n": _field("sensors", "force_noise_n", "force_noise_n"),
    "torque_noise_nm": _field("sensors", "torque_noise_nm", "torque_noise_nm"),
}
#: Every key an env's options may hold.
OPTION_KEYS = tuple(_OPTIONS)


def apply_options(scenario: Scenario, *layers: Mapping[str, Any]) -> Scenario:
    """``scenario`` with the variations in ``layers`` applied, later layers over earlier ones:
    key by key in the order of :data:`OPTION_KEYS`, so that a shape updates the one before it
    and a fibre direction from any layer turns the material from any layer.

    Values are checked as a scenario file's are (:func:`cell.config.updated`).

    Raises:
        InputError: an unknown key or a bad value; ``field`` names the key.
    """
    for options in layers:
        for key in options:
            if key not in _OPTIONS:
                raise InputError(None, key,
                                 f"unknown env option (known: {', '.join(OPTION_KEYS)})")
    for key, apply in _OPTIONS.items():
        for options in layers:
            if key in options:
                scenario = apply(scenario, options[key])
    return scenario
