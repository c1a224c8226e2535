"""Every named error musclecell raises, in one place.

All derive from :class:`MusclecellError`, so a caller can catch the family.
"""

from __future__ import annotations

import functools
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


class OutputError(InputError):
    """An output path that cannot be written: a folder where a file goes (or a file where a
    folder goes), a parent that is not a folder or not writable, the same file as an input.
    Raised before any work, so that nothing is written. ``field`` is the option that named it.

    Example:
        >>> raise OutputError("scenarios/default.toml", "output", "is the scenario read")
        Traceback (most recent call last):
        cell.errors.OutputError: scenarios/default.toml, output: is the scenario read
    """


class FileReadError(InputError):
    """An input file that cannot be read as text of its kind (:func:`cell.io.read_text`).

    The reader raises the fault's own class combined with the error of what was being read
    (:func:`file_read_error`): a scenario that is a folder is both a :class:`NotAFileError` and
    a :class:`ScenarioError`.

    Example:
        >>> raise file_read_error(NotTextError, ScenarioError)("s.toml", None, "not UTF-8 text")
        Traceback (most recent call last):
        cell.errors.NotTextError: s.toml: not UTF-8 text
    """

    def __reduce__(self) -> tuple:
        parts = getattr(type(self), "_parts", None)
        if parts is None:
            return super().__reduce__()
        return _rebuilt_read_error, (*parts, self.file, self.field, self.message)


class MissingFileError(FileReadError):
    """No file at the path given."""


class NotAFileError(FileReadError):
    """A folder (or a device, a socket) where a file is expected."""


class UnreadableFileError(FileReadError):
    """A file the operating system does not let us read (permissions, an I/O error)."""


class FileTooLargeError(FileReadError):
    """A file larger than any real input of its kind (limits in :mod:`cell.io`)."""


class NotTextError(FileReadError):
    """A file that is not UTF-8 text (a binary file, another encoding) where text goes."""


@functools.cache
def file_read_error(fault: type[FileReadError], reading: type[InputError]
                    ) -> type[FileReadError]:
    """``fault`` that is also ``reading`` (the error of what was read): either catches it.

    Example:
        >>> issubclass(file_read_error(MissingFileError, SweepError), SweepError)
        True
    """
    if issubclass(fault, reading):
        return fault
    return type(fault.__name__, (fault, reading),
                {"__module__": __name__, "__doc__": fault.__doc__, "_parts": (fault, reading)})


def _rebuilt_read_error(fault: type[FileReadError], reading: type[InputError], file: str | None,
                        field: str | None, message: str) -> FileReadError:
    """The error :func:`file_read_error` made, rebuilt after crossing a process boundary."""
    return file_read_error(fault, reading)(file, field, message)


class ScenarioError(InputError):
    """A scenario TOML file with a wrong key, type or value."""


class ReachError(ScenarioError):
    """A plan that leaves an arm's reach or joint limits: names arm, waypoint and joint."""


class MaterialError(InputError):
    """A material definition with a missing, negative or inconsistent parameter."""


class CsvError(InputError):
    """A CSV table that cannot be read: missing column, a cell that is not a finite number."""


class MeasurementError(InputError):
    """A measurement set, or a request for one, with a wrong value (an unknown effect, no seed)."""


class CutTestError(MeasurementError):
    """A set's cut tests, or its ``[block]`` and ``[blade]`` tables, with a missing or wrong
    value: no ``[block]`` or ``[blade]`` where the set holds cuts, a missing column of the cut
    rows, time that does not increase within a cut test.

    Example:
        >>> raise CutTestError("set/specimen.toml", "blade", "missing table: the set holds cuts")
        Traceback (most recent call last):
        cell.errors.CutTestError: set/specimen.toml, blade: missing table: the set holds cuts
    """


class DirectionError(CutTestError):
    """A direction of the block or the blade that is not a unit vector, or a blade normal that
    is not perpendicular to the blade's edge."""


class EdgeInsideBlockError(CutTestError):
    """A cut test whose first sample puts the blade's edge inside the block: a cut starts with
    the edge outside the block or on its surface."""


class LogError(InputError):
    """A separation log (``log.toml`` and its channels, docs/logs.md) that cannot be read or
    replayed: a value that is not a finite number, a bad table or key.

    Example:
        >>> raise LogError("run/log.toml", "log.name", "expected text")
        Traceback (most recent call last):
        cell.errors.LogError: run/log.toml, log.name: expected text
    """


class MissingChannelError(LogError):
    """A log without one of its channels: a missing file (``knife.csv``, ``gripper.csv``,
    ``fixture.csv``) or a missing column of one."""


class SampleError(LogError):
    """A log's sample that is not a finite number (NaN, infinity, text), or a ``grasp`` that
    is neither 0 nor 1."""


class QuaternionError(LogError):
    """A pose whose quaternion is not a unit one (its norm off 1 by more than 1e-3)."""


class TimeOrderError(LogError):
    """A channel whose time does not increase from one sample to the next."""


class LogScenarioError(LogError):
    """A log whose ``scenario`` names no file."""


class LogBatchError(LogError):
    """Logs given as one batch (one batch of meat: docs/logs.md) that do not share their
    tools, sensors or material, fewer than two logs, or one log given twice."""


class RobotLogError(InputError):
    """A robot's log that cannot be imported as its mapping says; ``field`` names the topic.

    Example:
        >>> raise RobotLogError("trial.bag", "/ft/wrench", "no field wrench.force.x")
        Traceback (most recent call last):
        cell.errors.RobotLogError: trial.bag, /ft/wrench: no field wrench.force.x
    """


class MissingTopicError(RobotLogError):
    """A topic the mapping names that the log lacks (the message lists those it has)."""


class FrameError(RobotLogError):
    """A topic in another frame than the mapping gives it, or a wrench without its rotation."""


class NoContactError(RobotLogError):
    """A log in which the blade never meets the block."""


class MappingError(InputError):
    """A mapping file of ``musclecell import`` with a missing, unknown or bad key."""


class DiagnosisError(InputError):
    """Diagnosis settings out of range, or a cause the catalogue does not have."""


class RandomizationError(InputError):
    """A domain randomisation file with a wrong key, type, distribution or range."""


class LearningError(InputError):
    """A training or evaluation request that cannot run: an unknown env, a bad hyper-parameter,
    a seed in the evaluation range, no policy or checkpoint where one is named."""


class PickledPolicyError(LearningError):
    """A learned policy saved in an earlier release's pickled format (``policy.zip``,
    ``vecnormalize.pkl``): loading it would run whatever code its pickles hold, so it is
    refused; ``musclecell convert-policy RUN --trust-pickle`` converts a run you trust.

    Example:
        >>> raise PickledPolicyError("out/cut")
        Traceback (most recent call last):
        cell.errors.PickledPolicyError: out/cut: a policy in the pickled format of earlier ...
    """

    def __init__(self, file: str | Path | None, field: str | None = None,
                 message: str | None = None) -> None:
        super().__init__(file, field, message or (
            "a policy in the pickled format of earlier releases (policy.zip, vecnormalize.pkl), "
            "which is refused: loading it would run any code its pickles hold. If you trust "
            "where it came from, convert it once to the numbers-and-JSON format: "
            f"musclecell convert-policy {file} --trust-pickle"))


class SweepError(InputError):
    """A sweep file (or a sweep's results folder) with a wrong key, type, value or range."""


class PoolError(InputError):
    """A request to play runs side by side (:mod:`cell.scale.pool`: sweeps, batches, replays)
    that cannot be met: fewer than one worker, an address that is not a Ray cluster's or does
    not answer, no Ray; a run whose worker died. ``field``: the option (``--address``).

    Example:
        >>> raise PoolError(None, "--address", "not a Ray address: 'x'")
        Traceback (most recent call last):
        cell.errors.PoolError: --address: not a Ray address: 'x'
    """


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


class NotFiniteResultError(DivergenceError):
    """A result about to be written holds NaN or infinity: the computation that made it
    diverged, and its output is not data, so nothing is written (exit code 3, as a diverged
    simulation).

    Attributes:
        path: the file that was to be written.
        key: where in it the first non-finite value is (``baseline.rmse_n``, ``rows[3].gain``).

    Example:
        >>> raise NotFiniteResultError("out/d.json", "gain", "nan")
        Traceback (most recent call last):
        cell.errors.NotFiniteResultError: out/d.json, gain: nan is not a finite number;
        nothing written
    """

    def __init__(self, path: str | Path, key: str, value: str) -> None:
        self.path, self.key, self.value = str(path), key, value
        self.time_s = float("nan")
        self.reason = f"{key} is {value}"
        MusclecellError.__init__(self, f"{path}, {key}: {value} is not a finite number; "
                                 "nothing written")

    def __reduce__(self) -> tuple:
        return type(self), (self.path, self.key, self.value)


class FailedRowsError(MusclecellError):
    """A sweep or a batch ran to its end, its table and summary written whole, with
    ``failed`` of its ``rows`` (``what``: ``runs``, ``sets``) failed; the command exits 4.

    Example:
        >>> raise FailedRowsError("out/diagnoses", 1, 3, "sets")
        Traceback (most recent call last):
        cell.errors.FailedRowsError: out/diagnoses: 1 of 3 sets failed; their rows ... say why
    """

    def __init__(self, folder: str | Path, failed: int, rows: int, what: str) -> None:
        self.folder, self.failed, self.rows, self.what = str(folder), failed, rows, what
        super().__init__(f"{folder}: {failed} of {rows} {what} failed; their rows in the table "
                         "and summary.md say why")

    def __reduce__(self) -> tuple:
        return type(self), (self.folder, self.failed, self.rows, self.what)


class Stopped(KeyboardInterrupt):
    """The process was asked to stop by a signal (SIGTERM; SIGINT stays a plain
    :class:`KeyboardInterrupt`). Raised from the signal handler the command line installs, so
    that every ``finally`` and ``except BaseException`` on the way out removes its temporary
    files, as it does for Ctrl-C.

    Attributes:
        signal_number: the signal received; the command exits with 128 plus it.

    Example:
        >>> import signal
        >>> Stopped(signal.SIGTERM).exit_code
        143
    """

    def __init__(self, signal_number: int) -> None:
        self.signal_number = int(signal_number)
        super().__init__(f"stopped by signal {self.signal_number}")

    @property
    def exit_code(self) -> int:
        """The shell's convention for a process ended by a signal: 128 + its number."""
        return 128 + self.signal_number

    def __reduce__(self) -> tuple:
        return type(self), (self.signal_number,)
