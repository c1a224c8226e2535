"""Every named error musclecell raises, in one place.

All derive from :class:`MusclecellError`, so a caller can catch the family.
"""

from __future__ import annotations

from pathlib import Path


class MusclecellError(Exception):
    """Base class of every error raised by musclecell."""


class InputError(MusclecellError):
    """Bad user input: names the file and the field (key, line, column) at fault.

    Example:
        >>> raise InputError("scenarios/x.toml", "tissue.young_pa", "must be > 0, got -3")
        Traceback (most recent call last):
        cell.errors.InputError: scenarios/x.toml, tissue.young_pa: must be > 0, got -3
    """

    def __init__(self, file: str | Path | None, field: str | None, message: str) -> None:
        self.file = None if file is None else str(file)
        self.field = field
        self.message = message
        where = ", ".join(p for p in (self.file, field) if p)
        super().__init__(f"{where}: {message}" if where else message)

    def __reduce__(self) -> tuple:
        # Rebuilt from its own arguments when it crosses a process boundary.
        return type(self), (self.file, self.field, self.message)


class ScenarioError(InputError):
    """A scenario TOML file with a wrong key, type or value."""


class MaterialError(InputError):
    """A material definition with a missing, negative or inconsistent parameter."""


class CsvError(InputError):
    """A CSV table that cannot be read: missing column, a cell that is not a finite number."""


class MeasurementError(InputError):
    """A measurement set, or a request for one, with a wrong value (an unknown effect, no seed)."""


class DiagnosisError(InputError):
    """Diagnosis settings out of range, or a cause the catalogue does not have."""


class RandomizationError(InputError):
    """A domain randomisation file with a wrong key, type, distribution or range."""


class LearningError(InputError):
    """A training or evaluation request that cannot run: an unknown env, a bad
    hyper-parameter, a seed in the evaluation range, no policy or checkpoint where one is
    named."""


class SweepError(InputError):
    """A sweep file (or a sweep's results folder) with a wrong key, type, value or range, or
    a request to run one that cannot be met (no Ray where a cluster is named)."""


class MeshError(InputError):
    """A mesh that cannot be simulated: not a volume, inverted or degenerate elements."""


class NotWatertightError(MeshError):
    """A surface mesh that still has holes or open edges after repair, so it bounds no
    volume."""


class SelfIntersectionError(MeshError):
    """A surface mesh whose triangles cross each other, so it has no inside to fill."""


class NoInterfaceError(MeshError):
    """Two muscle surfaces that nowhere come within the interface tolerance of each other:
    there is no aponeurosis to bind."""


class TetrahedralisationError(MeshError):
    """A closed surface that the tetrahedral mesher could not fill with valid tets."""


class MissingExtraError(MusclecellError, ImportError):
    """An optional library a feature needs is not installed; the message names the extra.

    Example:
        >>> raise MissingExtraError("tetgen", "mesh", "surface_mesh")
        Traceback (most recent call last):
        cell.errors.MissingExtraError: surface_mesh needs tetgen: pip install 'musclecell[mesh]'
    """

    def __init__(self, module: str, extra: str, feature: str) -> None:
        self.module, self.extra, self.feature = module, extra, feature
        super().__init__(f"{feature} needs {module}: pip install 'musclecell[{extra}]'")

    def __reduce__(self) -> tuple:
        return type(self), (self.module, self.extra, self.feature)


class DivergenceError(MusclecellError):
    """The simulation blew up (NaN, MuJoCo warning, energy explosion); its state is not data.

    Attributes:
        time_s: simulated time at which the divergence was detected, in s.
        reason: what check fired.
    """

    def __init__(self, time_s: float, reason: str) -> None:
        self.time_s = time_s
        self.reason = reason
        super().__init__(f"simulation diverged at t = {time_s:.4f} s: {reason}")

    def __reduce__(self) -> tuple:
        return type(self), (self.time_s, self.reason)


class PerceptionError(MusclecellError):
    """The camera or the point cloud cannot give what was asked (no meat in view, empty cloud)."""


class ControlError(MusclecellError):
    """An IK target that cannot be reached or a controller used out of order."""
