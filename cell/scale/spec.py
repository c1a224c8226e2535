"""Sweep files: what a sweep runs (a base scenario, or an env and a policy), the changes every
run shares, and the variables it sweeps, read and checked.

A sweep file is TOML::

    [sweep]
    scenario = "../default.toml"   # the base scenario, relative to this file
    sampling = "grid"              # grid, random or latin-hypercube
    # runs = 24                    # random and latin-hypercube: how many
    seed = 0                       # run i plays seed + i; random draws follow it too
    record = false                 # a Rerun recording of each run

    [overrides]                    # the same change for every run, dotted scenario keys
    tissue.cell_size_m = 0.05

    [variables]                    # grid: the values; random and latin-hypercube: a range
    aponeurosis.stiffness_n_m = [25.0, 50.0, 100.0]
    cut.speed_m_s = { low = 0.02, high = 0.06 }   # add log = true for a log-uniform range

``run = "policy"`` in ``[sweep]`` plays a policy in an env instead (a ``[policy]`` table:
``env``, ``name`` of random, scripted or learned, ``folder`` of a learned one); its
overrides and variables are then the env's keyword arguments. Every fault raises
:class:`~cell.errors.SweepError` naming the file and the dotted key.

Example:
    >>> spec = load_sweep("scenarios/sweeps/binding_strength.toml")
    >>> spec.head.sampling, list(spec.variables)
    ('grid', ['aponeurosis.stiffness_n_m', 'cut.speed_m_s'])
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from cell.config import from_table, read_toml, require_non_negative, require_positive
from cell.errors import InputError, SweepError

Sampling = Literal["grid", "random", "latin-hypercube"]
RunKind = Literal["episode", "policy"]
Scalar = float | int | bool | str
#: The keys of a table that make it a range rather than a group of dotted keys.
_RANGE_KEYS = frozenset({"low", "high", "log"})
_TABLES = ("sweep", "policy", "overrides", "variables")


@dataclass(frozen=True)
class SweepHead:
    """The ``[sweep]`` table.

    Attributes:
        scenario: the base scenario file, relative to the sweep file (``run = "episode"``).
        sampling: ``grid`` (every combination of the listed values), ``random`` (uniform in
            each range) or ``latin-hypercube`` (one draw in each of ``runs`` strata per range).
        runs: how many runs random and Latin hypercube sampling draw.
        seed: run i plays seed ``seed + i``; random and Latin hypercube draws follow it too.
        record: write a Rerun recording of each episode.
        run: ``episode`` (the scripted episode of the scenario) or ``policy`` (``[policy]``).

    Example:
        >>> SweepHead(scenario="default.toml", sampling="random", runs=8).seed
        0
    """

    scenario: str = ""
    sampling: Sampling = "grid"
    runs: int | None = None
    seed: int = 0
    record: bool = False
    run: RunKind = "episode"

    def __post_init__(self) -> None:
        require_non_negative(self, "seed")
        if self.runs is not None:
            require_positive(self, "runs")


@dataclass(frozen=True)
class PolicyTarget:
    """The ``[policy]`` table of a policy sweep: ``env`` (Gymnasium id), the policy's
    ``name`` and, for a learned one, its ``folder`` (relative to the sweep file).

    Example:
        >>> PolicyTarget("musclecell/Cut-v2", "learned")
        Traceback (most recent call last):
        cell.errors.InputError: folder: a learned policy needs its folder
    """

    env: str
    name: Literal["random", "scripted", "learned"] = "scripted"
    folder: str = ""

    def __post_init__(self) -> None:
        if self.name == "learned" and not self.folder:
            raise InputError(None, "folder", "a learned policy needs its folder")


@dataclass(frozen=True)
class Range:
    """A swept variable's range for random and Latin hypercube sampling, in the key's own
    unit: uniform in [low, high], or log-uniform with ``log`` (then low > 0).

    Example:
        >>> Range(0.02, 0.06).high
        0.06
        >>> Range(0.0, 1.0, log=True)
        Traceback (most recent call last):
        cell.errors.InputError: low: must be > 0 for a log range, got 0.0
    """

    low: float
    high: float
    log: bool = False

    def __post_init__(self) -> None:
        if not self.low < self.high:
            raise InputError(None, "high", f"must be > low ({self.low}), got {self.high}")
        if self.log and not self.low > 0:
            raise InputError(None, "low", f"must be > 0 for a log range, got {self.low}")


@dataclass(frozen=True)
class SweepSpec:
    """A sweep file, read: where it is, its head, the policy of a policy sweep, the shared
    overrides and the variables (dotted key to values or :class:`Range`, in the key's own
    SI unit), in file order.

    Example:
        >>> spec = SweepSpec(Path("sweeps/s.toml"), SweepHead(scenario="../default.toml"),
        ...                  variables={"cut.speed_m_s": (0.03, 0.06)})
        >>> spec.scenario_path.as_posix()
        'sweeps/../default.toml'
    """

    path: Path
    head: SweepHead
    policy: PolicyTarget | None = None
    overrides: dict[str, Scalar] = field(default_factory=dict)
    variables: dict[str, tuple[Scalar, ...] | Range] = field(default_factory=dict)

    @property
    def scenario_path(self) -> Path:
        """The base scenario, resolved against the sweep file's folder."""
        return self.path.parent / self.head.scenario

    @property
    def policy_folder(self) -> Path:
        """A learned policy's folder, resolved against the sweep file's folder."""
        return self.path.parent / (self.policy.folder if self.policy else "")


def load_sweep(path: str | Path) -> SweepSpec:
    """Read and check a sweep file (module docstring).

    Raises:
        SweepError: naming the file and the dotted key at fault.
    """
    path = Path(path)
    raw = read_toml(path, SweepError)
    unknown = sorted(set(raw) - set(_TABLES))
    if unknown:
        raise SweepError(path, unknown[0], f"unknown table (known: {', '.join(_TABLES)})")
    for name in _TABLES:
        if not isinstance(raw.get(name, {}), dict):
            raise SweepError(path, name, "expected a table")
    head = from_table(SweepHead, raw.get("sweep", {}), file=path, section="sweep",
                      error=SweepError)
    policy = None
    if head.run == "policy":
        if "policy" not in raw:
            raise SweepError(path, "policy", 'run = "policy" needs a [policy] table')
        policy = from_table(PolicyTarget, raw["policy"], file=path, section="policy",
                            error=SweepError)
        for key, given in (("scenario", head.scenario), ("record", head.record)):
            if given:
                raise SweepError(path, f"sweep.{key}", "only for run = \"episode\": a policy "
                                 "sweep plays the env's own scenario, unrecorded")
    elif "policy" in raw:
        raise SweepError(path, "policy", 'only a sweep with run = "policy" has one')
    elif not head.scenario:
        raise SweepError(path, "sweep.scenario", "missing: the base scenario file")
    overrides = _leaves(raw.get("overrides", {}), "overrides", path)
    variables = {key: _variable(value, head.sampling, path, f"variables.{key}")
                 for key, value in _leaves(raw.get("variables", {}), "variables", path).items()}
    if not variables:
        raise SweepError(path, "variables", "missing: at least one variable to sweep")
    if head.sampling == "grid" and head.runs is not None:
        raise SweepError(path, "sweep.runs", "a grid runs every combination: leave runs out")
    if head.sampling != "grid" and head.runs is None:
        raise SweepError(path, "sweep.runs", f"missing: how many {head.sampling} runs")
    both = sorted(set(overrides) & set(variables))
    if both:
        raise SweepError(path, f"variables.{both[0]}", "also in [overrides]: give it once")
    return SweepSpec(path, head, policy, overrides, variables)


def _leaves(table: dict[str, Any], section: str, path: Path, prefix: str = ""
            ) -> dict[str, Any]:
    """Nested tables flattened to dotted keys (``a.b = 1`` and ``"a.b" = 1`` alike); a table
    of range keys is a leaf."""
    flat: dict[str, Any] = {}
    for key, value in table.items():
        dotted = f"{prefix}{key}"
        if isinstance(value, dict) and not (value and set(value) <= _RANGE_KEYS):
            if not value:
                raise SweepError(path, f"{section}.{dotted}", "empty table")
            flat |= _leaves(value, section, path, f"{dotted}.")
        else:
            flat[dotted] = value
    return flat


def _variable(value: Any, sampling: str, path: Path, where: str) -> tuple[Scalar, ...] | Range:
    """A variable's values (grid) or range (random, Latin hypercube), checked."""
    if sampling == "grid":
        if not isinstance(value, list) or not value:
            raise SweepError(path, where, f"a grid needs a non-empty list of values, got "
                             f"{value!r}")
        for item in value:
            if isinstance(item, list | dict):
                raise SweepError(path, where, f"values must be numbers, booleans or strings, "
                                 f"got {item!r}")
        if len(set(map(repr, value))) != len(value):
            raise SweepError(path, where, f"a value is listed twice: {value!r}")
        return tuple(value)
    if not isinstance(value, dict):
        raise SweepError(path, where, f"{sampling} sampling needs a range "
                         f"{{ low = ..., high = ... }}, got {value!r}")
    return from_table(Range, value, file=path, section=where, error=SweepError)
