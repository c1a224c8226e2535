"""Cut tests in a measurement set: read beside uniaxial tests or alone, as robots log them
(irregular and dropped samples, an offset in air), and every bad input named, through the
Python API and the command line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cell.cli import main
from cell.errors import (
    CsvError,
    CutTestError,
    DirectionError,
    EdgeInsideBlockError,
    InputError,
)
from cell.measure.cuts import Blade, Block, CutTest
from cell.measure.specimens import SPECIMEN_FILE, TESTS_FILE, load_measurement_set
from tests.refusals import snapshot

SPECIMEN = """[specimen]
name = "cube"
size_m = [0.010, 0.010, 0.010]
"""
BLOCK = """[block]
size_m = [0.060, 0.040, 0.030]
fibre_direction = [1.0, 0.0, 0.0]
"""
BLADE = """[blade]
edge_length_m = 0.12
thickness_m = 0.0015
edge_angle_deg = 20.0
edge_direction = [0.0, 1.0, 0.0]
blade_normal = [1.0, 0.0, 0.0]
"""
CUT_HEADER = ("test_id,mode,time_s,edge_x_m,edge_y_m,edge_z_m,force_x_N,force_y_N,force_z_N,"
              "torque_x_Nm,torque_y_Nm,torque_z_Nm")
UNIAXIAL_HEADER = "test_id,mode,angle_deg,time_s,displacement_m,force_N"
UNIAXIAL_ROWS = ["a,tension,0,0.0,0.0,0.0", "a,tension,0,0.5,0.00005,0.01",
                 "a,tension,0,1.0,0.0001,0.02"]
#: A press cut as a robot logs it: uneven steps, a dropped sample (0.02 to 0.05 s), the
#: sensor reading 1.5 N in air before the edge meets the top face at z = 0.030.
PRESS_ROWS = [
    "p,cut,0.000,0.03,0.02,0.0320,0.1,-0.2,1.5,0.0,0.0,0.0",
    "p,cut,0.010,0.03,0.02,0.0310,0.1,-0.2,1.5,0.0,0.0,0.0",
    "p,cut,0.020,0.03,0.02,0.0300,0.1,-0.2,1.6,0.0,0.0,0.0",
    "p,cut,0.050,0.03,0.02,0.0270,0.2,-0.1,4.0,0.0,0.01,0.0",
    "p,cut,0.061,0.03,0.02,0.0259,0.2,-0.1,5.5,0.0,0.01,0.0",
]
#: A sawing cut: the edge moves along y while it sinks.
SAW_ROWS = [
    "s,cut,0.00,0.03,0.020,0.030,0.0,0.0,1.0,0,0,0",
    "s,cut,0.10,0.03,0.030,0.029,0.0,-1.0,3.0,0,0,0",
    "s,cut,0.20,0.03,0.020,0.028,0.0,1.0,3.0,0,0,0",
]


def _write_set(folder: Path, specimen: str, tests: list[str]) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / SPECIMEN_FILE).write_text(specimen)
    (folder / TESTS_FILE).write_text("\n".join(tests) + "\n")
    return folder


def _cut_set(folder: Path, specimen: str = BLOCK + BLADE,
             rows: list[str] | None = None, header: str = CUT_HEADER) -> Path:
    return _write_set(folder, specimen, [header, *(PRESS_ROWS if rows is None else rows)])


def _replaced(rows: list[str], index: int, column: int, value: str) -> list[str]:
    """``rows`` with one cell replaced."""
    cells = rows[index].split(",")
    cells[column] = value
    return [*rows[:index], ",".join(cells), *rows[index + 1:]]


def _mixed_lines() -> list[str]:
    """A mixed tests.csv: the uniaxial test ``a`` and the press cut ``p``, interleaved, each
    row leaving the other kind's columns empty."""
    cut_columns = CUT_HEADER.split(",", 3)[3]
    empty_cut = "," * len(cut_columns.split(","))
    lines = [f"{UNIAXIAL_HEADER},{cut_columns}", f"{UNIAXIAL_ROWS[0]}{empty_cut}"]
    for row in PRESS_ROWS:
        test_id, mode, time, rest = row.split(",", 3)
        lines.append(f"{test_id},{mode},,{time},,,{rest}")
    return lines + [f"{row}{empty_cut}" for row in UNIAXIAL_ROWS[1:]]


def test_a_cut_set_reads_as_a_robot_logs_it(tmp_path: Path) -> None:
    data = load_measurement_set(_cut_set(tmp_path / "set", rows=[*PRESS_ROWS, *SAW_ROWS]))
    assert data.specimen is None and data.tests == ()
    assert data.block == Block((0.06, 0.04, 0.03), (1.0, 0.0, 0.0))
    assert data.blade == Blade(0.12, 0.0015, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), 20.0)
    press, saw = data.cut_tests
    assert (press.test_id, saw.test_id) == ("p", "s")
    np.testing.assert_array_equal(press.time_s, [0.0, 0.01, 0.02, 0.05, 0.061])
    np.testing.assert_allclose(press.force_n[0], [0.1, -0.2, 1.5])  # the offset is data
    assert press.edge_m.shape == (5, 3) and press.torque_nm is not None
    assert not press.force_n.flags.writeable
    np.testing.assert_allclose(press.depth_m(data.block)[[0, -1]], [-0.002, 0.0041])
    np.testing.assert_allclose(saw.stroke_m(data.blade), [0.0, 0.01, 0.0])
    np.testing.assert_allclose(press.stroke_m(data.blade), 0.0)


def test_torque_is_optional_and_the_edge_may_start_on_or_beside_the_block(
        tmp_path: Path) -> None:
    header = CUT_HEADER.rsplit(",", 3)[0]
    rows = [row.rsplit(",", 3)[0] for row in PRESS_ROWS]
    (test,) = load_measurement_set(_cut_set(tmp_path / "a", rows=rows, header=header)).cut_tests
    assert test.torque_nm is None
    starts = {"on the top face": (0.03, 0.02, 0.030), "just inside the top face":
              (0.03, 0.02, 0.02995), "beside the block": (-0.01, 0.02, 0.02),
              "past its far end": (0.03, 0.045, 0.01)}
    for name, start in starts.items():
        first = _replaced(_replaced(_replaced(rows, 0, 3, str(start[0])), 0, 4, str(start[1])),
                          0, 5, str(start[2]))
        folder = _cut_set(tmp_path / name.replace(" ", "-"), rows=first, header=header)
        assert load_measurement_set(folder).cut_tests[0].edge_m[0].tolist() == list(start)


def test_a_mixed_set_reads_both_kinds_and_the_uniaxial_tests_as_alone(tmp_path: Path) -> None:
    alone = load_measurement_set(_write_set(tmp_path / "alone", SPECIMEN,
                                            [UNIAXIAL_HEADER, *UNIAXIAL_ROWS]))
    assert (alone.block, alone.blade, alone.cut_tests) == (None, None, ())
    data = load_measurement_set(_write_set(tmp_path / "mixed", SPECIMEN + BLOCK + BLADE,
                                           _mixed_lines()))
    (test,), (cut,) = data.tests, data.cut_tests
    reference = alone.tests[0]
    for name in ("time_s", "displacement_m", "force_n"):
        np.testing.assert_array_equal(getattr(test, name), getattr(reference, name))
    assert data.specimen == alone.specimen
    assert cut.test_id == "p" and len(cut.time_s) == len(PRESS_ROWS)


def test_the_types_check_themselves() -> None:
    with pytest.raises(DirectionError):
        Block((0.06, 0.04, 0.03), (1.0, 1.0, 0.0))
    with pytest.raises(DirectionError):
        Blade(0.1, 0.001, (0.0, 1.0, 0.0), (0.0, 0.6, 0.8))
    with pytest.raises(InputError, match="strictly increasing"):
        CutTest("c", np.array([0.0, 1.0, 1.0]), np.zeros((3, 3)), np.zeros((3, 3)))
    with pytest.raises(InputError, match="shape"):
        CutTest("c", np.array([0.0, 1.0]), np.zeros((3, 3)), np.zeros((2, 3)))
    # 0.707 is meant as a unit vector's component.
    assert Blade(0.1, 0.001, (0.0, 0.707, 0.707), (1.0, 0.0, 0.0)).edge_direction[1] == 0.707


# (name, specimen.toml, expected class, field, words)
TOML_CASES = [
    ("no block", BLADE, CutTestError, "block", "missing table"),
    ("no blade", BLOCK, CutTestError, "blade", "missing table"),
    ("fibre not unit", BLOCK.replace("[1.0, 0.0, 0.0]", "[2.0, 0.0, 0.0]") + BLADE,
     DirectionError, "block.fibre_direction", "unit vector"),
    ("edge not unit", BLOCK + BLADE.replace("edge_direction = [0.0, 1.0, 0.0]",
                                            "edge_direction = [0.0, 0.9, 0.0]"),
     DirectionError, "blade.edge_direction", "unit vector"),
    ("normal not perpendicular", BLOCK + BLADE.replace("blade_normal = [1.0, 0.0, 0.0]",
                                                       "blade_normal = [0.0, 1.0, 0.0]"),
     DirectionError, "blade.blade_normal", "perpendicular"),
    ("zero thickness", BLOCK + BLADE.replace("0.0015", "0.0"), CutTestError,
     "blade.thickness_m", "> 0"),
    ("absurd block", BLOCK.replace("0.060", "60.0") + BLADE, CutTestError, "block.size_m",
     "not plausible"),
    ("nan in toml", BLOCK + BLADE.replace("0.12", "nan"), CutTestError, "blade.edge_length_m",
     "finite"),
    ("bevel angle", BLOCK + BLADE.replace("20.0", "200.0"), CutTestError,
     "blade.edge_angle_deg", "between 0 and 180"),
    ("unknown key", BLOCK + BLADE + "colour = 'red'\n", CutTestError, "blade.colour",
     "unknown key"),
]


@pytest.mark.parametrize(("specimen", "error", "field", "words"),
                         [c[1:] for c in TOML_CASES], ids=[c[0] for c in TOML_CASES])
def test_bad_block_or_blade_names_file_and_key(tmp_path: Path, specimen: str,
                                               error: type[InputError], field: str,
                                               words: str) -> None:
    folder = _cut_set(tmp_path / "set", specimen)
    with pytest.raises(error) as raised:
        load_measurement_set(folder)
    assert type(raised.value) is error
    assert raised.value.file == str(folder / SPECIMEN_FILE)
    assert raised.value.field == field
    assert words in raised.value.message


def test_a_set_with_uniaxial_tests_needs_its_specimen(tmp_path: Path) -> None:
    folder = _write_set(tmp_path / "set", BLOCK + BLADE, _mixed_lines())
    with pytest.raises(InputError) as raised:
        load_measurement_set(folder)
    assert (raised.value.file, raised.value.field) == (str(folder / SPECIMEN_FILE), "specimen")
    assert "uniaxial" in raised.value.message


# (name, rows, header, expected class, field, words)
CSV_CASES = [
    ("edge starts inside", _replaced(PRESS_ROWS, 0, 5, "0.020"), CUT_HEADER,
     EdgeInsideBlockError, "line 2, column edge_z_m", "inside the block"),
    ("nan force", _replaced(PRESS_ROWS, 2, 7, "nan"), CUT_HEADER, CsvError,
     "line 4, column force_y_N", "not finite"),
    ("inf edge", _replaced(PRESS_ROWS, 3, 3, "inf"), CUT_HEADER, CsvError,
     "line 5, column edge_x_m", "not finite"),
    ("empty cell", _replaced(PRESS_ROWS, 1, 8, ""), CUT_HEADER, CsvError,
     "line 3, column force_z_N", "not a number"),
    ("stray quote", _replaced(PRESS_ROWS, 1, 6, '"0.1'), CUT_HEADER, CsvError,
     "line 3, column force_y_N", "missing value"),
    ("time repeats", _replaced(PRESS_ROWS, 2, 2, "0.010"), CUT_HEADER, CutTestError,
     "line 4, column time_s", "must increase"),
    ("time backwards", _replaced(PRESS_ROWS, 3, 2, "0.001"), CUT_HEADER, CutTestError,
     "line 5, column time_s", "must increase"),
    ("absurd force", _replaced(PRESS_ROWS, 4, 8, "1e9"), CUT_HEADER, CsvError,
     "line 6, column force_z_N", "not plausible"),
    ("absurd edge", _replaced(PRESS_ROWS, 4, 5, "-300"), CUT_HEADER, CsvError,
     "line 6, column edge_z_m", "not plausible"),
    ("absurd torque", _replaced(PRESS_ROWS, 4, 10, "1e6"), CUT_HEADER, CsvError,
     "line 6, column torque_y_Nm", "not plausible"),
    ("missing force column", [r.rsplit(",", 4)[0] for r in PRESS_ROWS],
     CUT_HEADER.rsplit(",", 4)[0], CsvError, "line 1, column force_z_N", "missing column"),
    ("one torque column missing", [r.rsplit(",", 1)[0] for r in PRESS_ROWS],
     CUT_HEADER.rsplit(",", 1)[0], CsvError, "line 1, column torque_z_Nm",
     "missing column"),
    ("mode changes", _replaced(PRESS_ROWS, 3, 1, "tension"), CUT_HEADER, CutTestError,
     "line 5, column mode", "changes mode"),
    ("too few samples", PRESS_ROWS[:2], CUT_HEADER, CutTestError, "line 2, column test_id",
     "needs at least 3"),
]


@pytest.mark.parametrize(("rows", "header", "error", "field", "words"),
                         [c[1:] for c in CSV_CASES], ids=[c[0] for c in CSV_CASES])
def test_bad_cut_rows_name_file_line_and_column(tmp_path: Path, rows: list[str], header: str,
                                                error: type[InputError], field: str,
                                                words: str) -> None:
    folder = _cut_set(tmp_path / "set", rows=rows, header=header)
    before = snapshot(tmp_path)
    with pytest.raises(error) as raised:
        load_measurement_set(folder)
    assert type(raised.value) is error
    assert raised.value.file == str(folder / TESTS_FILE)
    assert raised.value.field == field
    assert words in raised.value.message
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize(("specimen", "rows", "named"), [
    (BLADE, PRESS_ROWS, ("specimen.toml", "block", "missing table")),
    (BLOCK, PRESS_ROWS, ("specimen.toml", "blade", "missing table")),
    (BLOCK + BLADE.replace("edge_direction = [0.0, 1.0, 0.0]",
                           "edge_direction = [0.0, 0.9, 0.0]"), PRESS_ROWS,
     ("specimen.toml", "blade.edge_direction", "unit vector")),
    (BLOCK + BLADE.replace("[1.0, 0.0, 0.0]", "[0.0, 1.0, 0.0]"), PRESS_ROWS,
     ("specimen.toml", "blade.blade_normal", "perpendicular")),
    (BLOCK + BLADE, _replaced(PRESS_ROWS, 0, 5, "0.02"),
     ("tests.csv", "line 2, column edge_z_m", "inside the block")),
    (BLOCK + BLADE, _replaced(PRESS_ROWS, 2, 7, "nan"),
     ("tests.csv", "line 4, column force_y_N")),
    (BLOCK + BLADE, _replaced(PRESS_ROWS, 3, 2, "0.001"),
     ("tests.csv", "line 5, column time_s")),
], ids=["no block", "no blade", "not unit", "normal", "inside", "nan", "time"])
def test_diagnose_refuses_a_bad_cut_set_and_writes_nothing(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture,
        specimen: str, rows: list[str], named: tuple[str, ...]) -> None:
    _cut_set(tmp_path / "set", specimen, rows)
    (tmp_path / "out").mkdir()
    monkeypatch.chdir(tmp_path)
    before = snapshot(tmp_path)
    assert main(["diagnose", "set", "--out", "out/d.json"]) == 2
    message = capsys.readouterr().err
    assert "Traceback" not in message
    for word in named:
        assert word in message, message
    assert snapshot(tmp_path) == before


def test_diagnose_diagnoses_a_good_cut_set(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # A set holding cuts is read whole (every error above is found), then its cut tests are
    # diagnosed (cell.diagnosis.sets): the JSON has their part, the material a
    # [cutting] table.
    _cut_set(tmp_path / "set")
    monkeypatch.chdir(tmp_path)
    assert main(["diagnose", "set", "--out", "d.json"]) == 0
    assert "cut" in json.loads((tmp_path / "d.json").read_text())
    assert "[cutting]" in (tmp_path / "d-material.toml").read_text()
