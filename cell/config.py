"""Typed loading of TOML tables into parameter dataclasses, with errors that name file and key.

One loader serves scenarios and material files: every table maps onto a frozen dataclass,
unknown keys and wrong types are refused, and value checks in the dataclass's
``__post_init__`` (raising :class:`~cell.errors.InputError`) are re-raised with the file and
the dotted key. The plausible range of each physical quantity that inputs give
(:class:`Plausible`: forces, sizes, moduli, times) is here too, in one place.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
import types
import typing
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

from cell.errors import InputError, ScenarioError
from cell.io import read_text

T = TypeVar("T")


def read_toml(path: str | Path, error: type[InputError] = ScenarioError) -> dict[str, Any]:
    """Parse a TOML file read by :func:`cell.io.read_text`.

    Raises:
        FileReadError: (also an ``error``) a file that is missing, a folder, unreadable, too
            large or not text.
        InputError: (``error``) not valid TOML.

    Example:
        >>> read_toml("assets/materials/beef_default.toml")["model"]
        'mass_spring'
    """
    path = Path(path)
    text = read_text(path, "toml", error)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(path, None, f"not valid TOML: {exc}") from None


def _check_type(value: Any, annotation: Any, where: str, file: Path | None, error: type) -> Any:
    """Return ``value`` converted to ``annotation`` (int to float, list to tuple) or raise."""
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        options = typing.get_args(annotation)
        if value is None and type(None) in options:
            return None
        for option in options:
            if option is type(None):
                continue
            try:
                return _check_type(value, option, where, file, error)
            except InputError:
                continue
        raise error(file, where, f"expected {annotation}, got {type(value).__name__} {value!r}")
    if origin is tuple:
        args = typing.get_args(annotation)
        if not isinstance(value, list | tuple):
            raise error(file, where, f"expected a list, got {type(value).__name__}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_check_type(v, args[0], where, file, error) for v in value)
        if len(value) != len(args):
            raise error(file, where, f"expected {len(args)} values, got {len(value)}")
        pairs = zip(value, args, strict=True)
        return tuple(_check_type(v, a, where, file, error) for v, a in pairs)
    if origin is typing.Literal:
        if value not in typing.get_args(annotation):
            choices = ", ".join(repr(a) for a in typing.get_args(annotation))
            raise error(file, where, f"must be one of {choices}, got {value!r}")
        return value
    if annotation is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise error(file, where, f"expected a number, got {type(value).__name__} {value!r}")
        if not math.isfinite(value):
            raise error(file, where, f"must be finite, got {value!r}")
        return float(value)
    if annotation is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise error(file, where, f"expected an integer, got {type(value).__name__} {value!r}")
        return value
    if annotation is bool:
        if not isinstance(value, bool):
            raise error(file, where, f"must be true or false, got {value!r}")
        return value
    if annotation is str:
        if not isinstance(value, str):
            raise error(file, where, f"expected text, got {type(value).__name__} {value!r}")
        return value
    if dataclasses.is_dataclass(annotation):
        if not isinstance(value, dict):
            raise error(file, where, f"expected a table, got {type(value).__name__}")
        return from_table(annotation, value, file=file, section=where, error=error)
    raise TypeError(f"unsupported annotation {annotation!r} for {where}")


def from_table(
    cls: type[T],
    table: dict[str, Any],
    *,
    file: str | Path | None = None,
    section: str = "",
    error: type[InputError] = ScenarioError,
) -> T:
    """Build dataclass ``cls`` from a TOML table; missing keys take the dataclass defaults.

    Example:
        >>> from cell.tissue.geometry import MuscleShape
        >>> from_table(MuscleShape, {"length_m": 0.4}, file="s.toml", section="tissue").length_m
        0.4
        >>> from_table(MuscleShape, {"length_m": -0.4}, file="s.toml", section="tissue")
        Traceback (most recent call last):
        cell.errors.ScenarioError: s.toml, tissue.length_m: must be > 0, got -0.4
    """
    file = None if file is None else Path(file)
    kwargs = _checked_fields(cls, table, file, section, error)
    for required in dataclasses.fields(cls):
        if (required.init and required.name not in kwargs
                and required.default is dataclasses.MISSING
                and required.default_factory is dataclasses.MISSING):
            where = f"{section}.{required.name}" if section else required.name
            raise error(file, where, "missing key: it has no default")
    return _build(lambda: cls(**kwargs), file, section, error)


def updated(
    instance: T,
    table: Mapping[str, Any],
    *,
    file: str | Path | None = None,
    section: str = "",
    error: type[InputError] = InputError,
) -> T:
    """``instance`` (a dataclass) with the fields in ``table`` replaced, checked as
    :func:`from_table` checks a TOML table: unknown keys, wrong types and values out of range
    raise ``error`` naming the dotted key (the key changed, when a single change breaks the
    check of another field).

    Example:
        >>> from cell.tissue.geometry import MuscleShape
        >>> updated(MuscleShape(cell_size_m=0.05), {"length_m": 0.4}).cell_size_m
        0.05
        >>> updated(MuscleShape(), {"length_m": "long"}, section="shape")
        Traceback (most recent call last):
        cell.errors.InputError: shape.length_m: expected a number, got str 'long'
    """
    file = None if file is None else Path(file)
    if not isinstance(table, Mapping):
        raise error(file, section or None, f"expected a table, got {type(table).__name__}")
    kwargs = _checked_fields(type(instance), table, file, section, error)

    def replaced() -> T:
        try:
            return dataclasses.replace(instance, **kwargs)
        except InputError as exc:
            if len(kwargs) != 1 or exc.field in kwargs:
                raise
            # A check of another field that this change broke: the change is what to fix.
            (key, value), = kwargs.items()
            raise InputError(None, key, f"{value!r} is refused by the check of "
                             f"{exc.field}: {exc.message}") from None

    return _build(replaced, file, section, error)


def _checked_fields(cls: type, table: Mapping[str, Any], file: Path | None, section: str,
                    error: type[InputError]) -> dict[str, Any]:
    """``table``'s values checked against ``cls``'s field types (converted where the types
    allow), by field name."""
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    kwargs: dict[str, Any] = {}
    for key, value in table.items():
        where = f"{section}.{key}" if section else key
        if key not in fields:
            known = ", ".join(sorted(fields))
            raise error(file, where, f"unknown key (known keys: {known})")
        kwargs[key] = _check_type(value, hints[key], where, file, error)
    return kwargs


def _build(make: Callable[[], T], file: Path | None, section: str,
           error: type[InputError]) -> T:
    """``make()``, its value checks re-raised as ``error`` naming file and dotted key."""
    try:
        return make()
    except InputError as exc:
        where = exc.field or section
        if section and exc.field and not exc.field.startswith(f"{section}."):
            where = f"{section}.{exc.field}"
        # A check that raised a narrower error of the same family keeps its class.
        named = type(exc) if isinstance(exc, error) else error
        raise named(file, where, exc.message) from None
    except TypeError as exc:  # a check in __post_init__ that met a type it did not expect
        raise error(file, section or None, str(exc)) from None


@dataclass(frozen=True)
class Plausible:
    """The values a quantity of one unit takes in any real input, bounds included. Outside
    them a finite value is a typo or a wrong unit (mm written for m), never a measurement, and
    it would make the numbers downstream overflow; the bounds are generous so that no real
    input trips them.

    Attributes:
        low: the smallest plausible value, in ``unit``.
        high: the largest plausible value, in ``unit``.
        unit: the SI unit, for messages.
        reason: why these bounds, for messages.

    Example:
        >>> FORCE_N.check(1e308, "set/tests.csv", "line 9, column force_N")
        Traceback (most recent call last):
        cell.errors.InputError: set/tests.csv, line 9, column force_N: 1e+308 N is not
        plausible (allowed -100000 to 100000 N: the largest load cells ...)
    """

    low: float
    high: float
    unit: str
    reason: str

    def refusal(self, value: float) -> str | None:
        """Why ``value`` is refused, or None when it is plausible."""
        if self.low <= value <= self.high:
            return None
        return (f"{value:g} {self.unit} is not plausible (allowed {self.low:g} to "
                f"{self.high:g} {self.unit}: {self.reason})")

    def check(self, value: float, file: str | Path | None, where: str | None,
              error: type[InputError] = InputError) -> None:
        """Raise ``error`` naming ``file`` and ``where`` if ``value`` is not plausible."""
        refusal = self.refusal(value)
        if refusal is not None:
            raise error(file, where, refusal)

    def first_outside(self, values: Sequence[float]) -> int | None:
        """The index of the first of ``values`` that is not plausible, or None."""
        return next((i for i, v in enumerate(values) if not self.low <= v <= self.high), None)


#: Force measured on a specimen or a knife, N.
FORCE_N = Plausible(-1e5, 1e5, "N", "the largest load cells of materials-testing machines "
                    "read 100 kN; a tissue test reads less than 1 kN")
#: A size: a specimen's edge, a muscle's dimension, m.
LENGTH_M = Plausible(1e-6, 10.0, "m", "nothing in the cell is smaller than a micrometre or "
                     "larger than the cell's few metres")
#: A procedural muscle's length, width or height, m.
MUSCLE_SIZE_M = Plausible(0.03, 2.0, "m", "a beef muscle is 5 to 60 cm; the camera's view and "
                          "the arms' reach are laid out for muscles of that size")
#: A displacement put on a specimen, m (either sign).
DISPLACEMENT_M = Plausible(-10.0, 10.0, "m", "no test moves a platen further than the cell is "
                           "large")
#: A time in a measured history, s.
TIME_S = Plausible(-1e7, 1e7, "s", "about four months; the longest creep tests last days")
#: A fibre angle, degrees.
ANGLE_DEG = Plausible(-360.0, 360.0, "deg", "a full turn either way")
#: A modulus of soft tissue, Pa.
MODULUS_PA = Plausible(1.0, 1e10, "Pa", "soft tissue is stiffer than 100 Pa (brain) and "
                       "softer than 2 GPa (tendon); bone is 10 GPa")
#: A nominal stress on a specimen (force over its cross-section), Pa.
STRESS_PA = Plausible(-1e9, 1e9, "Pa", "tendon breaks near 100 MPa; no soft tissue carries "
                      "1 GPa")
#: The least peak stress a measurement set must reach, Pa: soft tissue carries more at any
#: strain a test reaches (brain, the softest, about 10 Pa at 1 %). Below it the set holds
#: nothing but the load cell's noise, and a fit makes a material of no stiffness at all.
MEASURABLE_STRESS_PA = 0.1
#: A mass density, kg/m^3.
DENSITY_KG_M3 = Plausible(1.0, 3e4, "kg/m^3", "tissue is about 1060; no solid is lighter "
                          "than aerogel or heavier than osmium")


def require_positive(owner: object, *names: str, error: type[InputError] = InputError) -> None:
    """Raise ``error`` naming the first of ``owner``'s fields ``names`` (all of its dataclass
    fields when none are named) that is not > 0. For ``__post_init__`` checks.

    Example:
        >>> from dataclasses import dataclass
        >>> @dataclass
        ... class Blade:
        ...     length_m: float
        ...     speed_m_s: float
        >>> require_positive(Blade(0.1, 0.02))
        >>> require_positive(Blade(0.1, -0.02), "speed_m_s")
        Traceback (most recent call last):
        cell.errors.InputError: speed_m_s: must be > 0, got -0.02
    """
    _require(owner, names, lambda value: value > 0, "> 0", error)


def require_non_negative(owner: object, *names: str,
                         error: type[InputError] = InputError) -> None:
    """Like :func:`require_positive`, for fields that must be >= 0."""
    _require(owner, names, lambda value: value >= 0, ">= 0", error)


def require_flag(owner: object, *names: str, error: type[InputError] = InputError) -> None:
    """Raise ``error`` naming the first of ``owner``'s fields ``names`` that is not a bool.

    Example:
        >>> from dataclasses import dataclass
        >>> @dataclass
        ... class Knife:
        ...     enabled: bool
        >>> require_flag(Knife(1), "enabled")
        Traceback (most recent call last):
        cell.errors.InputError: enabled: must be true or false, got 1
    """
    for name in names:
        value = getattr(owner, name)
        if not isinstance(value, bool):
            raise error(None, name, f"must be true or false, got {value!r}")


def require_count(owner: object, name: str, least: int,
                  error: type[InputError] = InputError) -> None:
    """Raise ``error`` naming ``owner``'s field ``name`` unless it is an integer (not a bool)
    of at least ``least``."""
    value = getattr(owner, name)
    if isinstance(value, bool) or not (isinstance(value, int) and value >= least):
        raise error(None, name, f"must be an integer >= {least}, got {value!r}")


def _require(owner: object, names: tuple[str, ...], holds: Any, bound: str,
             error: type[InputError]) -> None:
    for name in names or tuple(f.name for f in dataclasses.fields(owner)):
        value = getattr(owner, name)
        if not holds(value):
            raise error(None, name, f"must be {bound}, got {value}")

