"""Typed loading of TOML tables into parameter dataclasses, with errors that name file and key.

One loader serves scenarios and material files: every table maps onto a frozen dataclass,
unknown keys and wrong types are refused, and value checks in the dataclass's
``__post_init__`` (raising :class:`~cell.errors.InputError`) are re-raised with the file and
the dotted key.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
import types
import typing
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, TypeVar

from cell.errors import InputError, ScenarioError

T = TypeVar("T")


def read_toml(path: str | Path, error: type[InputError] = ScenarioError) -> dict[str, Any]:
    """Parse a TOML file, turning a syntax error or a missing file into ``error``."""
    path = Path(path)
    try:
        with path.open("rb") as handle:
            return tomllib.load(handle)
    except FileNotFoundError:
        raise error(path, None, "file not found") from None
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
    if annotation is bool or annotation is str:
        if not isinstance(value, annotation):
            raise error(file, where, f"expected {annotation.__name__}, got {value!r}")
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
    raise ``error`` naming the dotted key.

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
    return _build(lambda: dataclasses.replace(instance, **kwargs), file, section, error)


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
        where = f"{section}.{exc.field}" if section and exc.field else (exc.field or section)
        raise error(file, where, exc.message) from None
    except TypeError as exc:  # a required field without default
        raise error(file, section or None, str(exc)) from None


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

