"""Fuzzing the TOML readers: scenarios, materials, sweep files and randomisation files of random
tables, keys, types and values (NaN, infinities, 1e308, wrong types, stray keys), and every text
reader fed binary junk. Each must return or raise a named error (:mod:`tests.fuzzing`); the
``slow`` variants run 10 000 examples each (40 through the command line, a process each).
"""

from __future__ import annotations

import dataclasses
import typing
from pathlib import Path
from typing import Any

from hypothesis import strategies as st

from cell.config import read_toml
from cell.errors import FileReadError, InputError, ScenarioError
from cell.io import read_text
from cell.measure.specimens import load_measurement_set, load_specimen, load_tests
from cell.scale.spec import load_sweep
from cell.scale.sweep import prepare
from cell.sim.scenario import Scenario, load_scenario
from cell.tissue.forcecurve import ForceCurve
from cell.tissue.material import ContinuumMaterial, MassSpringMaterial
from cell.tissue.materialfile import load_material
from envs.options import OPTION_KEYS
from envs.randomization import load_randomization
from tests.fuzzing import (
    check_named,
    documents,
    fuzz_tests,
    mostly,
    numbers,
    scratch,
    toml_document,
    values,
    words,
    written,
)
from tests.paths import DEFAULT_SCENARIO
from tests.refusals import refused


def _fields(cls: Any) -> tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(cls) if f.init)


def _scenario_keys() -> dict[str, tuple[str, ...]]:
    """Each table of a scenario file and its keys."""
    hints = typing.get_type_hints(Scenario)
    keys = {"scenario": ("name", "seed", "settle_s", "end_s"),
            "material": ("file", "model", *_fields(MassSpringMaterial),
                         *_fields(ContinuumMaterial))}
    for field in dataclasses.fields(Scenario):
        kind = hints[field.name]
        if dataclasses.is_dataclass(kind):
            keys[field.name] = _fields(kind)
    return keys


SCENARIO_KEYS = _scenario_keys()
CURVE_KEYS = ("modulus_pa", "coefficients", "r_min", "r_max", "exponent")
MATERIAL_KEYS = {"": ("model", *_fields(MassSpringMaterial), *_fields(ContinuumMaterial))}
SWEEP_KEYS = {"sweep": ("scenario", "sampling", "runs", "seed", "record", "run"),
              "overrides": tuple(f"{t}.{k}" for t, ks in SCENARIO_KEYS.items() for k in ks),
              "variables": tuple(f"{t}.{k}" for t, ks in SCENARIO_KEYS.items() for k in ks)}
RANDOMIZATION_KEYS = {key: ("kind", "low", "high", "values", "log") for key in OPTION_KEYS}


def _mostly_numbers(table: str, key: str) -> st.SearchStrategy[Any]:
    """Known keys mostly get numbers, so that the checks past the types are reached."""
    return mostly(numbers(), values(), 4)


# -- scenarios ------------------------------------------------------------------------------

def _check_scenario(document: dict[str, Any]) -> None:
    with scratch() as folder:
        path = written(Path(folder), {"s.toml": toml_document(document)}) / "s.toml"
        check_named(lambda: load_scenario(path))


test_scenario_files, test_scenario_files_slow = fuzz_tests(
    documents(SCENARIO_KEYS, _mostly_numbers), _check_scenario, 300)


# -- materials ------------------------------------------------------------------------------

@st.composite
def _materials(draw: st.DrawFn) -> dict[str, Any]:
    document = draw(documents({"longitudinal": CURVE_KEYS, "transverse": CURVE_KEYS,
                               "transverse_compression": CURVE_KEYS}, _mostly_numbers))
    top = draw(st.dictionaries(st.sampled_from(MATERIAL_KEYS[""]), st.one_of(numbers(), values()),
                               max_size=5))
    top["model"] = draw(st.sampled_from(["mass_spring", "continuum", "rubber"]))
    return {**top, **document}


def _check_material(document: dict[str, Any]) -> None:
    with scratch() as folder:
        path = written(Path(folder), {"m.toml": toml_document(document)}) / "m.toml"
        check_named(lambda: load_material(path))


test_material_files, test_material_files_slow = fuzz_tests(_materials(), _check_material, 200)


# -- sweep files ----------------------------------------------------------------------------

@st.composite
def _sweeps(draw: st.DrawFn) -> dict[str, Any]:
    variable = st.one_of(st.lists(numbers(), max_size=3),
                         st.fixed_dictionaries({"low": numbers(), "high": numbers()}), values())
    document = draw(documents(SWEEP_KEYS, lambda table, key: (
        variable if table == "variables" else st.one_of(numbers(), values()))))
    head = document.setdefault("sweep", {})
    if isinstance(head, dict) and draw(mostly(st.just(True), st.just(False), 4)):
        head["scenario"] = str(DEFAULT_SCENARIO)
    return document


def _check_sweep(document: dict[str, Any]) -> None:
    with scratch() as folder:
        path = written(Path(folder), {"w.toml": toml_document(document)}) / "w.toml"

        def read() -> None:
            spec = load_sweep(path)
            if spec.policy is None:
                prepare(spec)

        check_named(read)


test_sweep_files, test_sweep_files_slow = fuzz_tests(_sweeps(), _check_sweep, 200)


# -- randomisation files --------------------------------------------------------------------

def _check_randomization(document: dict[str, Any]) -> None:
    with scratch() as folder:
        path = written(Path(folder), {"r.toml": toml_document(document)}) / "r.toml"
        check_named(lambda: load_randomization(path))


test_randomization_files, test_randomization_files_slow = fuzz_tests(
    documents(RANDOMIZATION_KEYS, lambda table, key: st.one_of(
        numbers(), st.sampled_from(["uniform", "choice", "normal"]), values())),
    _check_randomization, 100)


# -- any text reader, fed junk --------------------------------------------------------------

#: Each reader of a text file, by the file name it reads.
READERS = {
    "scenario.toml": load_scenario,
    "material.toml": load_material,
    "sweep.toml": load_sweep,
    "randomization.toml": load_randomization,
    "specimen.toml": load_specimen,
    "tests.csv": load_tests,
    "curve.csv": ForceCurve.from_csv,
}


def _check_junk(case: tuple[str, bytes]) -> None:
    name, content = case
    with scratch() as folder:
        path = written(Path(folder), {name: content}) / name
        try:
            READERS[name](path)
        except InputError as error:
            assert error.file is not None and Path(error.file).name == name, error
            if b"\0" in content:
                assert isinstance(error, FileReadError), error


test_junk_files, test_junk_files_slow = fuzz_tests(
    st.tuples(st.sampled_from(sorted(READERS)), st.one_of(
        st.binary(max_size=200), st.text(max_size=100).map(str.encode),
        st.binary(max_size=40).map(lambda junk: b"[specimen]\nname = 'x'\n" + junk))),
    _check_junk, 300)


def _check_set_folder(case: tuple[str | None, str | None]) -> None:
    """A set whose files are missing, folders, or junk text."""
    with scratch() as folder:
        root = Path(folder) / "set"
        root.mkdir()
        for name, content in zip(("specimen.toml", "tests.csv"), case, strict=True):
            if content == "<folder>":
                (root / name).mkdir()
            elif content is not None:
                (root / name).write_text(content)
        check_named(lambda: load_measurement_set(root))


test_set_folders, test_set_folders_slow = fuzz_tests(
    st.tuples(st.one_of(st.none(), st.just("<folder>"), words()),
              st.one_of(st.none(), st.just("<folder>"), words())), _check_set_folder, 60)


def test_a_text_reader_names_the_fault_and_keeps_the_caller_s_error(tmp_path: Path) -> None:
    (tmp_path / "junk.toml").write_bytes(b"\xff\xfe\x00binary")
    for path, fault in ((tmp_path / "junk.toml", "not UTF-8 text"),
                        (tmp_path, "a folder, not a file"),
                        (tmp_path / "gone.toml", "file not found"),
                        (tmp_path / "junk.toml" / "x.toml", "a part of its path is a file")):
        try:
            read_toml(path)
        except ScenarioError as error:
            assert isinstance(error, FileReadError) and fault in error.message, error
        else:
            raise AssertionError(f"{path} was read")
    (tmp_path / "bom.toml").write_text("\ufeffa = 1\n")  # as some editors save it
    assert read_text(tmp_path / "bom.toml", "toml") == "a = 1\n"


# -- through the command line, a few examples (each is a process) ---------------------------

def _check_cli_scenario(case: tuple[dict[str, Any], bytes]) -> None:
    """A fuzzed scenario made sure to be bad (a stray table), or binary junk after a good
    line: ``plan`` exits 2 with the file named, no traceback, the working folder as it was."""
    document, junk = case
    with scratch() as folder:
        cwd = Path(folder)
        content = (toml_document({**document, "stray": {"x": 1}}).encode() if not junk
                   else b"[scenario]\n" + junk)
        written(cwd, {"s.toml": content, "out/kept.txt": "before\n"})
        refused(cwd, "plan", "s.toml", "--out", "out/plan.json", words=("s.toml",))


test_cli_scenarios, test_cli_scenarios_slow = fuzz_tests(
    st.tuples(documents(SCENARIO_KEYS, _mostly_numbers),
              st.one_of(st.just(b""), st.binary(min_size=1, max_size=64).map(
                  lambda junk: b"\xff" + junk))), _check_cli_scenario, 3, slow_examples=40)
