"""Domain randomisation: what differs from one carcass to the next and one cell to the next,
as a distribution the envs draw their reset options from.

A randomisation file (TOML; the package's default is ``assets/randomization/default.toml``)
holds one table per varied option of :mod:`envs.options` (the muscle shape's fields under
``[tissue.<field>]``), each a :class:`Distribution` in the option's own SI units::

    [aponeurosis_stiffness_n_m]
    kind = "uniform"
    low = 35.0
    high = 65.0

The previous release's option names (:data:`envs.options.RENAMED_OPTIONS`, ``[shape.*]``
among them) still load, with a ``FutureWarning`` naming the file and the new name.

Every range is checked where it is loaded: its bounds (all corners of the shape's ranges
together; a choice's smallest and largest values) must make a valid scenario, so a draw holds
no value its parameter refuses (the shape's checks bound convex or multilinear functions of
its fields, whose worst case over a box lies at a corner). A shape can still fail as a mesh, or a
world diverge; the envs draw again then.

Example:
    >>> import numpy as np
    >>> randomization = load_randomization()
    >>> world = draw(randomization, np.random.default_rng(0))
    >>> 35.0 <= world["aponeurosis_stiffness_n_m"] <= 65.0
    True
    >>> 0.40 <= world["tissue"]["length_m"] <= 0.50
    True
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, Literal

import numpy as np
from cell.assets import asset_path

from cell.config import from_table, read_toml
from cell.errors import InputError, RandomizationError
from cell.sim.scenario import Scenario
from cell.tissue.shape import MuscleShape
from envs.options import OPTION_KEYS, apply_options, renamed

#: The package's default distribution.
DEFAULT_RANDOMIZATION = asset_path("randomization/default.toml")
#: Options that are no single number and so are not drawn (the tissue is drawn field by field).
_NOT_DRAWN = ("tissue", "material", "fibre_direction")
#: A scan's files are no number to draw either.
_SHAPE_FIELDS = tuple(f.name for f in fields(MuscleShape)
                      if f.name not in ("cell_size_m", "surface_mesh"))


@dataclass(frozen=True)
class Distribution:
    """One option's distribution, in the option's units.

    ``kind``: ``"uniform"`` on [``low``, ``high``], ``"normal"`` with ``mean`` and ``std``
    clipped to [``low``, ``high``], or ``"choice"`` among ``values`` (equally likely).
    ``size``: how many independent values one draw gives (3 for a vector such as a sensor
    bias); 1 draws a number.

    Example:
        >>> import numpy as np
        >>> Distribution("normal", low=-0.1, high=0.1, mean=0.0, std=1.0).sample(
        ...     np.random.default_rng(0))
        0.1
        >>> Distribution("uniform", low=2.0, high=1.0)
        Traceback (most recent call last):
        cell.errors.InputError: low: must be <= high (1.0), got 2.0
    """

    kind: Literal["uniform", "normal", "choice"]
    low: float | None = None
    high: float | None = None
    mean: float | None = None
    std: float | None = None
    values: tuple[float, ...] = ()
    size: int = 1

    def __post_init__(self) -> None:
        ranged = self.kind != "choice"
        needed = {"uniform": ("low", "high"), "normal": ("low", "high", "mean", "std"),
                  "choice": ("values",)}[self.kind]
        for name in ("low", "high", "mean", "std", "values"):
            given = getattr(self, name) not in (None, ())
            if given != (name in needed):
                raise InputError(None, name, f"{'needed' if not given else 'not taken'} by "
                                 f"kind = {self.kind!r} (it takes {', '.join(needed)})")
        if ranged and self.low > self.high:
            raise InputError(None, "low", f"must be <= high ({self.high}), got {self.low}")
        if self.kind == "normal":
            if not self.std >= 0.0:
                raise InputError(None, "std", f"must be >= 0, got {self.std}")
            if not self.low <= self.mean <= self.high:
                raise InputError(None, "mean", f"must be in [low, high], got {self.mean}")
        if self.size < 1:
            raise InputError(None, "size", f"must be >= 1, got {self.size}")

    @property
    def bounds(self) -> tuple[float, float]:
        """The smallest and the largest value a draw can give."""
        if self.kind == "choice":
            return min(self.values), max(self.values)
        return self.low, self.high

    def sample(self, rng: np.random.Generator) -> float | list[float]:
        """One draw: a number, or a list of ``size`` numbers."""
        if self.kind == "uniform":
            values = rng.uniform(self.low, self.high, self.size)
        elif self.kind == "normal":
            values = np.clip(rng.normal(self.mean, self.std, self.size), self.low, self.high)
        else:
            values = np.asarray(self.values)[rng.integers(len(self.values), size=self.size)]
        values = [float(v) for v in values]
        return values[0] if self.size == 1 else values


@dataclass(frozen=True)
class Randomization:
    """A distribution over the envs' reset options: (dotted key, distribution) pairs, drawn
    in this order; shape fields are keyed ``tissue.<field>``. ``source`` names the file.

    Example:
        >>> Randomization((("force_scale", Distribution("uniform", low=0.8, high=1.2)),)
        ...               ).keys
        ('force_scale',)
    """

    entries: tuple[tuple[str, Distribution], ...]
    source: str | None = None

    @property
    def keys(self) -> tuple[str, ...]:
        """The dotted keys drawn."""
        return tuple(key for key, _ in self.entries)


def load_randomization(path: str | Path | None = None,
                       scenario: Scenario | None = None) -> Randomization:
    """Read a randomisation file (the package's default when None) and check its ranges on
    ``scenario`` (the default :class:`Scenario` when None).

    Raises:
        RandomizationError: a missing file, an unknown key, a wrong type, ``low > high``, a
            range its option refuses; names the file and the dotted key.
    """
    path = Path(DEFAULT_RANDOMIZATION if path is None else path)
    document = read_toml(path, error=RandomizationError)
    try:
        raw = renamed(document, str(path))
    except InputError as exc:
        raise RandomizationError(path, exc.field, exc.message) from None
    entries: list[tuple[str, Distribution]] = []
    for key, table in raw.items():
        if key == "tissue" and isinstance(table, dict):
            for name, sub in table.items():
                if name not in _SHAPE_FIELDS:
                    raise RandomizationError(path, f"tissue.{name}", "unknown shape field "
                                             f"(known: {', '.join(_SHAPE_FIELDS)})")
                entries.append((f"tissue.{name}", _distribution(path, f"tissue.{name}", sub)))
        elif key in OPTION_KEYS and key not in _NOT_DRAWN:
            entries.append((key, _distribution(path, key, table)))
        else:
            known = ("tissue", *(k for k in OPTION_KEYS if k not in _NOT_DRAWN))
            raise RandomizationError(path, key, f"unknown key (known: {', '.join(known)})")
    randomization = Randomization(tuple(entries), str(path))
    check_ranges(randomization, Scenario() if scenario is None else scenario)
    return randomization


def _distribution(path: Path, key: str, table: Any) -> Distribution:
    if not isinstance(table, dict):
        raise RandomizationError(path, key, f"expected a table, got {type(table).__name__}")
    return from_table(Distribution, table, file=path, section=key, error=RandomizationError)


def check_ranges(randomization: Randomization, scenario: Scenario) -> None:
    """Raise :class:`RandomizationError` naming the dotted key of the first range whose bounds
    ``scenario`` refuses: each option's at both ends, the shape's at every corner of its
    ranges (its checks couple fields)."""
    shape_ranges: dict[str, tuple[float, float]] = {}
    for key, distribution in randomization.entries:
        if key.startswith("tissue."):
            shape_ranges[key.removeprefix("tissue.")] = distribution.bounds
            continue
        for bound in distribution.bounds:
            value = bound if distribution.size == 1 else [bound] * distribution.size
            _check(randomization, scenario, key, {key: value})
    for corner in itertools.product(*shape_ranges.values()):
        _check(randomization, scenario, "tissue", {"tissue": dict(zip(shape_ranges, corner,
                                                                     strict=True))})


def _check(randomization: Randomization, scenario: Scenario, key: str,
           options: dict[str, Any]) -> None:
    try:
        apply_options(scenario, options)
    except InputError as exc:
        raise RandomizationError(randomization.source, exc.field or key,
                                 f"the range reaches {options[key]}: {exc.message}") from None


def draw(randomization: Randomization, rng: np.random.Generator) -> dict[str, Any]:
    """Reset options drawn from ``randomization`` (see :mod:`envs.options`): one value per
    key, the shape's fields gathered under ``"tissue"``. Pure: no scene is built.

    Example:
        >>> r = Randomization((("tissue.length_m", Distribution("choice", values=(0.4,))),))
        >>> draw(r, np.random.default_rng(1))
        {'tissue': {'length_m': 0.4}}
    """
    options: dict[str, Any] = {}
    for key, distribution in randomization.entries:
        value = distribution.sample(rng)
        if key.startswith("tissue."):
            options.setdefault("tissue", {})[key.removeprefix("tissue.")] = value
        else:
            options[key] = value
    return options
