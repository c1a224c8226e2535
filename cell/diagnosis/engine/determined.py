"""Numbers a diagnosis computes about its own fits (a parameter's interval, a held-out error, a
gain, an information criterion, a magnitude) as a reader gets them: the number where the data
determine it, and where they do not (a singular covariance, a prediction that overflowed)
``null`` in the JSON with the reason beside it (``"ci95": null, "ci95_reason": "..."``) and
"not determined" in a report. The uniaxial, the cut and the log diagnoses all go through
:func:`determined`, so that no NaN or infinity of a fit reaches the strict JSON writer
(:func:`cell.outputs.write_json`), which keeps refusing them for what they mean there: a
simulation that diverged.

Example:
    >>> determined("ci95", [0.1, float("nan")])
    {'ci95': None, 'ci95_reason': 'not identifiable from these tests'}
    >>> determined("gain", 0.42), shown(float("inf"), ".3g")
    ({'gain': 0.42}, 'not determined')
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: Why a parameter's interval is null: the tests do not bound it (a flat or singular misfit
#: along it).
NOT_IDENTIFIABLE = "not identifiable from these tests"
#: The same for a magnitude of the log diagnosis.
NOT_IN_LOGS = "not identifiable from these logs"
#: Why a held-out score is null: a prediction of a test left out did not stay finite.
NOT_PREDICTED = "a held-out prediction did not stay finite"
#: What a report shows for a number that is not determined.
NOT_DETERMINED = "not determined"


def is_determined(value: Any) -> bool:
    """``value`` (a number, or a sequence or array of them) is finite throughout.

    Example:
        >>> is_determined([1.0, 2.0]), is_determined(float("nan")), is_determined(None)
        (True, False, False)
    """
    if value is None:
        return False
    numbers = np.asarray(value, dtype=float)
    return bool(numbers.size == 0 or np.isfinite(numbers).all())


def determined(name: str, value: Any, reason: str = NOT_IDENTIFIABLE) -> dict[str, Any]:
    """``{name: value}`` when ``value`` is finite throughout (an array as a list), else
    ``{name: None, name_reason: reason}``: the JSON entry of a number a fit may not determine.

    Example:
        >>> determined("ci95", np.array([0.5, 1.5]))
        {'ci95': [0.5, 1.5]}
    """
    if not is_determined(value):
        return {name: None, f"{name}_reason": reason}
    if isinstance(value, np.ndarray):
        return {name: value.tolist()}
    if isinstance(value, np.floating | float) and not isinstance(value, bool):
        return {name: float(value)}
    return {name: value}


def determined_each(values: dict[str, Any], reason: str = NOT_IDENTIFIABLE) -> dict[str, Any]:
    """Every entry of ``values`` through :func:`determined` (a fit's parameters by name).

    Example:
        >>> determined_each({"yield_strain": 0.03, "toughness_j_m2": math.inf})
        ... # doctest: +NORMALIZE_WHITESPACE
        {'yield_strain': 0.03, 'toughness_j_m2': None,
         'toughness_j_m2_reason': 'not identifiable from these tests'}
    """
    return {key: item for name, value in values.items()
            for key, item in determined(name, value, reason).items()}


def estimates_json(estimates: dict[str, tuple[float, float, float]]) -> dict[str, Any]:
    """Fitted parameters by name, each ``(value, low, high)`` of its 95 % interval, as the
    JSON's ``{"value": ..., "ci95": [low, high]}``, an interval the data do not bound ``null``
    with its ``ci95_reason``.

    Example:
        >>> estimates_json({"hardening": (0.02, math.nan, math.nan)})
        ... # doctest: +NORMALIZE_WHITESPACE
        {'hardening': {'value': 0.02, 'ci95': None,
                       'ci95_reason': 'not identifiable from these tests'}}
    """
    return {name: {**determined("value", value), **determined("ci95", [low, high])}
            for name, (value, low, high) in estimates.items()}


def finite_or_none(value: float) -> float | None:
    """``value`` where it is finite, else None: a cell of a table (blank in a CSV) whose
    reason the row's JSON gives.

    Example:
        >>> finite_or_none(0.5), finite_or_none(math.inf)
        (0.5, None)
    """
    return value if value is not None and math.isfinite(value) else None


def shown(value: float | None, spec: str) -> str:
    """``value`` formatted with ``spec`` where it is finite, else :data:`NOT_DETERMINED`.

    Example:
        >>> shown(0.12345, ".3g"), shown(math.nan, ".3g"), shown(None, ".3g")
        ('0.123', 'not determined', 'not determined')
    """
    return NOT_DETERMINED if finite_or_none(value) is None else format(value, spec)
