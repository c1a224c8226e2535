"""``musclecell diagnose --batch``: every measurement set in a folder diagnosed, one Ray task
per set, into one table of causes and gains; a re-run skips the sets already diagnosed.

Each set is diagnosed as ``musclecell diagnose`` diagnoses it, through the same entry point
(:func:`cell.diagnosis.sets.diagnose_set`): uniaxial tests, cut tests or both. The
results folder gets ``diagnoses.parquet`` and ``diagnoses.csv`` (one row per set),
``summary.md``, and per set ``sets/<set>.json`` (what ``musclecell diagnose --out`` writes)
and ``sets/<set>-material.toml`` (the extended material); a set that cannot be read or
diagnosed is a row with its error, and the others go on.
"""

from __future__ import annotations

import hashlib
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cell.diagnosis.engine.determined import finite_or_none, shown
from cell.diagnosis.engine.outcome import SearchOutcome
from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.sets import SetDiagnosis, diagnose_set
from cell.errors import InputError, MaterialError
from cell.io import read_bytes
from cell.measure.specimens import SPECIMEN_FILE, TESTS_FILE, MeasurementSet, load_measurement_set
from cell.outputs import first_non_finite, write_atomic, write_json
from cell.scale.failure import describe_failure
from cell.scale.pool import Workers
from cell.scale.resume import play_missing
from cell.scale.store import ResultsFolder
from cell.tissue.materialfile import material_to_toml

TABLE = "diagnoses"
#: The prefix of the columns of each kind of test's part of a diagnosis, in a row.
PARTS = {"uniaxial": "", "cut": "cut_"}
#: A part's columns (after the prefix): gain, noise (N), held-out RMSEs (N), extended model.
FIGURES = ("gain", "noise_n", "baseline_heldout_rmse_n", "extended_model",
           "extended_heldout_rmse_n")
#: The version of a set's record, hashed into its fingerprint: a folder of a batch before
#: version 2 (no ``tests`` column, no cut tests diagnosed) has every set diagnosed again.
RECORD_VERSION = 2


@dataclass(frozen=True)
class SetTask:
    """One set to diagnose (it pickles, for Ray): its ``name`` (its folder's), what was read,
    or the ``error`` that reading it gave."""

    name: str
    measurements: MeasurementSet | None
    params: DiagnosisParams
    error: str = ""


@dataclass(frozen=True)
class SetOutcome:
    """A diagnosed set: its ``row`` (set, specimen, status, error, the kinds of test it holds,
    each kind's gain, noise and held-out RMSEs in N (:data:`PARTS`, :data:`FIGURES`), the
    causes, wall time in s), the diagnosis's JSON and the extended material's TOML (None and
    empty when it failed) and a failure's traceback."""

    row: dict[str, Any]
    diagnosis: dict[str, Any] | None = None
    material_toml: str = ""
    traceback: str = ""


@dataclass(frozen=True)
class BatchOutcome:
    """A finished batch: every set's row (in name order), how many sets were diagnosed now
    and how many were found done in the folder, the wall time (s), the files written."""

    rows: list[dict[str, Any]]
    played: int
    skipped: int
    wall_s: float
    files: list[Path]


def set_folders(parent: str | Path) -> list[Path]:
    """The measurement sets in ``parent``: its sub-folders with a specimen or tests file (or
    a folder, or something unreadable, by either name: such a set is a failed row).

    Raises:
        InputError: ``parent`` is not a folder, or holds no set.
    """
    parent = Path(parent)
    if not parent.is_dir():
        raise InputError(parent, None, "not a folder of measurement sets")
    try:
        folders = sorted(p for p in parent.iterdir() if p.is_dir() and _holds_a_set(p))
    except OSError as exc:
        raise InputError(parent, None, f"cannot list the folder: {exc.strerror}") from None
    if not folders:
        raise InputError(parent, None, f"no measurement set in it (a folder with "
                         f"{SPECIMEN_FILE} and {TESTS_FILE})")
    return folders


def diagnose_task(task: SetTask) -> SetOutcome:
    """Diagnose one set, whatever tests it holds, as ``musclecell diagnose`` does
    (:func:`~cell.diagnosis.sets.diagnose_set`); never raises for the set's own faults
    (they are its status)."""
    started = time.perf_counter()
    row: dict[str, Any] = {"set": task.name}
    if task.measurements is None:
        return SetOutcome({**row, "status": "failed", "error": task.error})
    specimen = task.measurements.specimen  # None in a set of cut tests alone
    row["specimen"] = "" if specimen is None else specimen.name
    try:
        result = diagnose_set(task.measurements, task.params)
    except Exception as exc:  # one broken set is recorded as such, never stops the batch
        error, trace = describe_failure(exc)
        return SetOutcome({**row, "status": "failed", "error": error,
                           "wall_s": time.perf_counter() - started}, traceback=trace)
    # A score the fits do not determine is a blank cell (its reason in the set's JSON).
    row |= {"status": "ok", "error": "", **_part_columns(result),
            "causes": " ".join(result.causes), "wall_s": time.perf_counter() - started}
    diagnosis = result.to_json()
    # The diagnosis gives every number it computes finite or null with its reason
    # (cell.diagnosis.engine.determined); what else is not finite, or a fit that found no plausible
    # material, is the set's failure, not the batch's: it must not reach the strict writers.
    failed = {"set": task.name, "specimen": row["specimen"], "status": "failed",
              "wall_s": row["wall_s"]}
    diverged = first_non_finite({"row": row, "diagnosis": diagnosis})
    if diverged is not None:
        return SetOutcome({**failed, "error": "the diagnosis diverged: {} is {}".format(
            *diverged)})
    try:
        toml = material_to_toml(result.material(), result.material_comment())
    except MaterialError as exc:
        return SetOutcome({**failed, "error": f"the fitted material: {exc}"})
    return SetOutcome(row, diagnosis, toml)


def diagnose_batch(parent: str | Path, out: str | Path, workers: Workers,
                   params: DiagnosisParams | None = None, *, progress: bool = True
                   ) -> BatchOutcome:
    """Diagnose every set in ``parent`` (:func:`set_folders`) that ``out`` has not, then
    write the table and the summary of all of them. A set counts as done while its files and
    ``params`` are those it was diagnosed with.

    Raises:
        InputError: ``parent`` holds no set.
    """
    started = time.perf_counter()
    params = DiagnosisParams() if params is None else params
    folders = set_folders(parent)
    tasks = [_read(folder, params) for folder in folders]
    prints = [_fingerprint(folder, params) for folder in folders]
    results = ResultsFolder(out)
    sets = results.folder / "sets"

    def keep(name: str, outcome: SetOutcome | None, error: str) -> dict[str, Any]:
        if outcome is None:
            return {"row": {"set": name, "status": "failed", "error": error}, "traceback": ""}
        if outcome.diagnosis is not None:
            write_json(sets / f"{name}.json", outcome.diagnosis)
            write_atomic(sets / f"{name}-material.toml", outcome.material_toml)
        return {"row": outcome.row, "traceback": outcome.traceback}

    played = play_missing(diagnose_task, tasks, [task.name for task in tasks], prints, results,
                          workers, keep=keep, progress=progress, desc="diagnose")
    files = [*results.write_table(TABLE, played.rows),
             write_atomic(results.folder / "summary.md", summary_markdown(played.rows))]
    return BatchOutcome(played.rows, played.played, len(tasks) - played.played,
                        time.perf_counter() - started, files)


def summary_markdown(rows: list[dict[str, Any]]) -> str:
    """How many sets were diagnosed, how often each cause was found, each set's line (the
    gain and held-out RMSEs of each kind of test it holds, uniaxial first)."""
    done = [row for row in rows if row["status"] == "ok"]
    causes = Counter(cause for row in done for cause in row["causes"].split())
    lines = ["# Diagnoses", "", f"{len(rows)} sets: {len(done)} diagnosed, "
             f"{len(rows) - len(done)} failed.", "", "| cause | sets |", "|---|---|"]
    lines += [f"| {cause} | {count} |" for cause, count in causes.most_common()]
    lines += ["", "| set | tests | causes | gain | held-out RMSE (N) | error |",
              "|---|---|---|---|---|---|"]
    for row in rows:
        if row["status"] != "ok":
            lines.append(f"| {row['set']} | | | | | {row['error']} |")
            continue
        prefixes = [PARTS[kind] for kind in row["tests"].split()]
        gains = ", ".join(shown(row[f"{p}gain"], ".3f") for p in prefixes)
        rmses = ", ".join(f"{shown(row[f'{p}baseline_heldout_rmse_n'], '.3g')} -> "
                          f"{shown(row[f'{p}extended_heldout_rmse_n'], '.3g')}"
                          for p in prefixes)
        lines.append(f"| {row['set']} | {row['tests'].replace(' ', ', ')} | "
                     f"{row['causes'] or 'none'} | {gains} | {rmses} | |")
    return "\n".join(lines) + "\n"


def _part_columns(result: SetDiagnosis) -> dict[str, Any]:
    """The kinds of test the set holds (``tests``: ``uniaxial``, ``cut`` or both) and each
    part's :data:`FIGURES`, prefixed by :data:`PARTS` (empty for a kind the set lacks)."""
    parts: dict[str, SearchOutcome | None] = {"uniaxial": result.uniaxial, "cut": result.cut}
    columns: dict[str, Any] = {
        "tests": " ".join(kind for kind, part in parts.items() if part is not None)}
    for kind, part in parts.items():
        figures = {} if part is None else {
            "gain": finite_or_none(part.gain), "noise_n": part.noise_n,
            "baseline_heldout_rmse_n": finite_or_none(part.baseline.heldout_rmse_n),
            "extended_model": part.extended.model.name,
            "extended_heldout_rmse_n": finite_or_none(part.extended.heldout_rmse_n)}
        columns |= {f"{PARTS[kind]}{name}": figures.get(name) for name in FIGURES}
    return columns


def _read(folder: Path, params: DiagnosisParams) -> SetTask:
    """The set in ``folder``, read here (a cluster's nodes need not see the files)."""
    try:
        return SetTask(folder.name, load_measurement_set(folder), params)
    except InputError as exc:
        return SetTask(folder.name, None, params, str(exc))


def _holds_a_set(folder: Path) -> bool:
    """Whether ``folder`` has a specimen or tests file; one that cannot be looked into
    does (reading it then says why)."""
    try:
        return any((folder / name).exists() for name in (SPECIMEN_FILE, TESTS_FILE))
    except OSError:
        return True


def _fingerprint(folder: Path, params: DiagnosisParams) -> str:
    """The set's files, the diagnosis settings and :data:`RECORD_VERSION`, hashed; a file
    that cannot be read is hashed as its error (the set is then a failed row, re-tried when
    that changes)."""
    digest = hashlib.sha256(f"{RECORD_VERSION} {params!r}".encode())
    for name in (SPECIMEN_FILE, TESTS_FILE):
        try:
            digest.update(read_bytes(folder / name, "toml" if name == SPECIMEN_FILE else "csv"))
        except InputError as exc:
            digest.update(exc.message.encode())
    return digest.hexdigest()[:16]
