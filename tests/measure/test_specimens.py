"""Measurement sets: the example set, and every bad input of the format's error contract."""

from pathlib import Path

import numpy as np
import pytest

from cell.errors import InputError
from cell.measure.specimens import (
    MODES,
    SPECIMEN_FILE,
    TESTS_FILE,
    MechanicalTest,
    Specimen,
    load_measurement_set,
)
from tests.paths import EXAMPLE_SET

EXAMPLE = EXAMPLE_SET
SPECIMEN = """[specimen]
name = "cube"
size_m = [0.010, 0.010, 0.010]
density_kg_m3 = 1060.0
"""
HEADER = "test_id,mode,angle_deg,time_s,displacement_m,force_N"
ROWS = [
    "a,tension,0,0.0,0.0,0.0",
    "a,tension,0,0.5,0.00005,0.01",
    "a,tension,0,1.0,0.0001,0.02",
]


def _write_set(folder: Path, specimen: str | None = SPECIMEN,
               tests: str | None = "\n".join([HEADER, *ROWS])) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    if specimen is not None:
        (folder / SPECIMEN_FILE).write_text(specimen)
    if tests is not None:
        (folder / TESTS_FILE).write_text(tests + "\n")
    return folder


def test_example_set_loads_with_its_published_magnitudes() -> None:
    data = load_measurement_set(EXAMPLE)
    assert data.specimen.size_m == (0.01, 0.01, 0.01)
    assert data.specimen.density_kg_m3 == 1060.0
    assert "machine" in data.specimen.rig
    # Every condition is tested twice or more (other amplitude, angle or rate), so that
    # leave-one-test-out errors have a sibling to predict each test from.
    assert [t.test_id for t in data.tests] == [
        "t00", "t45", "t90", "c00", "c45", "c90", "c00-fast", "r00", "r90", "y00",
        "t00-10", "t45-10", "t90-10", "c00-20", "c45-20", "c90-20", "t00-fast", "c90-fast",
        "r45", "y90"]
    assert {t.mode for t in data.tests} == set(MODES)
    assert {t.angle_deg for t in data.tests} == {0.0, 45.0, 90.0}
    for mode in MODES:
        assert sum(t.mode == mode for t in data.tests) >= 2
    for mode in ("tension", "compression"):
        for angle in (0.0, 45.0, 90.0):
            assert sum(t.mode == mode and t.angle_deg == angle for t in data.tests) >= 2
    for test in data.tests:
        assert 150 <= len(test.time_s) <= 300
        assert (np.diff(test.time_s) >= 0).all()
        assert test.displacement_m[0] == 0.0
        assert not test.time_s.flags.writeable
    # Compression to stretch 0.7 at 1 %/s: 1.84 kPa along the fibres, 1.42 kPa across.
    for test_id, peak_pa in (("c00", 1.84e3), ("c90", 1.42e3)):
        stress = data.test(test_id).stress_pa(data.specimen)
        assert -stress.min() == pytest.approx(peak_pa, rel=0.03)
        assert data.test(test_id).strain(data.specimen).min() == pytest.approx(-0.3, abs=1e-3)
    fast = -data.test("c00-fast").stress_pa(data.specimen).min()
    assert fast / -data.test("c00").stress_pa(data.specimen).min() == pytest.approx(1.6, rel=0.05)
    for test_id in ("r00", "r45", "r90"):  # 53 to 73 % relaxation over a 300 s hold
        relaxation = data.test(test_id).stress_pa(data.specimen)
        assert 0.53 <= 1.0 - relaxation[-1] / relaxation.min() <= 0.73
    # Tension to stretch 1.15 at 1 %/s: 9.0 kPa along, 1.6 kPa at 45 degrees, 2.0 kPa across.
    for test_id, peak_pa in (("t00", 9.0e3), ("t45", 1.6e3), ("t90", 2.0e3)):
        test = data.test(test_id)
        assert test.stress_pa(data.specimen).max() == pytest.approx(peak_pa, rel=0.03)
        assert test.strain(data.specimen).max() == pytest.approx(0.15, abs=1e-3)
    sizes = sum(f.stat().st_size for f in EXAMPLE.iterdir())
    assert sizes < 200_000


def test_extra_columns_comments_uneven_samples_and_interleaved_tests(tmp_path: Path) -> None:
    folder = _write_set(tmp_path / "set", tests="\n".join([
        "# exported by the rig",
        "note,test_id,mode,angle_deg,time_s,displacement_m,force_N,temperature_C",
        "x,a,relaxation,45,0.0,0.0,0.0,4.0",
        "x,b,cyclic,90,0.0,0.0,0.0,4.0",
        "x,a,relaxation,45,0.1,-0.0001,-0.01,4.0",
        "",
        "x,b,cyclic,90,1.0,0.0001,0.01,4.0",
        "x,a,relaxation,45,5.0,-0.0001,-0.004,4.0",
        "x,b,cyclic,90,2.0,0.0,0.0,4.0",
        "x,a,relaxation,45,5.0,-0.0001,-0.004",  # a repeated time is not backwards
    ]))
    data = load_measurement_set(folder)
    a, b = data.tests
    assert (a.test_id, a.mode, a.angle_deg, b.test_id) == ("a", "relaxation", 45.0, "b")
    np.testing.assert_array_equal(a.time_s, [0.0, 0.1, 5.0, 5.0])
    np.testing.assert_array_equal(b.force_n, [0.0, 0.01, 0.0])
    assert data.specimen.rig == {}


def test_helpers_give_nominal_strain_and_stress() -> None:
    specimen = Specimen("box", (0.02, 0.01, 0.005))
    t = np.array([0.0, 1.0, 2.0])
    test = MechanicalTest("t", "tension", 0.0, t, 5e-4 * t, 0.2 * t)
    np.testing.assert_allclose(test.strain(specimen), [0.0, 0.1, 0.2])
    np.testing.assert_allclose(test.stress_pa(specimen), [0.0, 1e3, 2e3])


def test_reading_writes_nothing(tmp_path: Path) -> None:
    folder = _write_set(tmp_path / "set")
    before = sorted(p.name for p in folder.iterdir())
    load_measurement_set(folder)
    (folder / TESTS_FILE).write_text(HEADER + "\n")
    with pytest.raises(InputError):
        load_measurement_set(folder)
    assert sorted(p.name for p in folder.iterdir()) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["set"]


def _rows(*replace: tuple[int, str]) -> str:
    """The good CSV with rows replaced: (index into ROWS, new row)."""
    rows = list(ROWS)
    for index, row in replace:
        rows[index] = row
    return "\n".join([HEADER, *rows])


# (name, tests.csv, field expected in the error, words expected in the message)
CSV_CASES = [
    ("missing column", "\n".join(
        ["test_id,mode,angle_deg,time_s,displacement_m", *(r.rsplit(",", 1)[0] for r in ROWS)]),
     "line 1, column force_N", "missing column"),
    ("non-numeric", _rows((1, "a,tension,0,half,0.00005,0.01")), "line 3, column time_s",
     "not a number"),
    ("empty value", _rows((1, "a,tension,0,0.5,,0.01")), "line 3, column displacement_m",
     "not a number"),
    ("nan", _rows((2, "a,tension,0,1.0,0.0001,nan")), "line 4, column force_N", "not finite"),
    ("inf", _rows((2, "a,tension,0,1.0,inf,0.02")), "line 4, column displacement_m",
     "not finite"),
    ("non-finite angle", _rows((0, "a,tension,-inf,0.0,0.0,0.0")), "line 2, column angle_deg",
     "not finite"),
    ("time backwards", _rows((2, "a,tension,0,0.4,0.0001,0.02")), "line 4, column time_s",
     "backwards"),
    ("unknown mode", _rows((1, "a,torsion,0,0.5,0.00005,0.01")), "line 3, column mode",
     "unknown mode 'torsion'"),
    ("mode changes", _rows((2, "a,compression,0,1.0,0.0001,0.02")), "line 4, column mode",
     "changes mode"),
    ("angle changes", _rows((2, "a,tension,90,1.0,0.0001,0.02")), "line 4, column angle_deg",
     "changes angle"),
    ("too few samples", "\n".join([HEADER, *ROWS, "b,tension,0,0.0,0.0,0.0",
                                   "b,tension,0,1.0,0.0,0.0"]),
     "line 5, column test_id", "2 samples, needs at least 3"),
    ("short row", _rows((1, "a,tension,0,0.5")), "line 3, column displacement_m",
     "missing value"),
    ("empty test id", _rows((1, ",tension,0,0.5,0.00005,0.01")), "line 3, column test_id",
     "empty test id"),
]


@pytest.mark.parametrize(("tests", "field", "words"), [c[1:] for c in CSV_CASES],
                         ids=[c[0] for c in CSV_CASES])
def test_bad_tests_csv_names_file_line_and_column(
    tmp_path: Path, tests: str, field: str, words: str
) -> None:
    folder = _write_set(tmp_path / "set", tests=tests)
    with pytest.raises(InputError) as error:
        load_measurement_set(folder)
    assert error.value.file == str(folder / TESTS_FILE)
    assert error.value.field == field
    assert words in error.value.message
    assert str(folder / TESTS_FILE) in str(error.value) and field in str(error.value)


SPECIMEN_CASES = [
    ("zero size", SPECIMEN.replace("[0.010, 0.010, 0.010]", "[0.010, 0.0, 0.010]"),
     "specimen.size_m", "> 0"),
    ("negative size", SPECIMEN.replace("[0.010, 0.010, 0.010]", "[0.010, 0.010, -0.01]"),
     "specimen.size_m", "> 0"),
    ("two sizes", SPECIMEN.replace("[0.010, 0.010, 0.010]", "[0.010, 0.010]"),
     "specimen.size_m", "expected 3 values"),
    ("zero density", SPECIMEN.replace("1060.0", "0.0"), "specimen.density_kg_m3", "> 0"),
    ("unknown key", SPECIMEN + "colour = 'red'\n", "specimen.colour", "unknown key"),
    ("unknown table", SPECIMEN + "[notes]\ntext = 'x'\n", "notes", "unknown table"),
    ("missing table", "[rig]\nmachine = 'x'\n", "specimen", "missing table"),
    ("missing size", '[specimen]\nname = "cube"\n', "specimen.size_m", "missing key"),
    ("bad toml", "[specimen\n", None, "not valid TOML"),
]


@pytest.mark.parametrize(("specimen", "field", "words"), [c[1:] for c in SPECIMEN_CASES],
                         ids=[c[0] for c in SPECIMEN_CASES])
def test_bad_specimen_toml_names_file_and_key(
    tmp_path: Path, specimen: str, field: str | None, words: str
) -> None:
    folder = _write_set(tmp_path / "set", specimen=specimen)
    with pytest.raises(InputError) as error:
        load_measurement_set(folder)
    assert error.value.file == str(folder / SPECIMEN_FILE)
    assert error.value.field == field
    assert words in error.value.message


@pytest.mark.parametrize("missing", [SPECIMEN_FILE, TESTS_FILE])
def test_missing_file_is_named(tmp_path: Path, missing: str) -> None:
    folder = _write_set(tmp_path / "set")
    (folder / missing).unlink()
    with pytest.raises(InputError) as error:
        load_measurement_set(folder)
    assert error.value.file == str(folder / missing)
    assert "not found" in error.value.message


@pytest.mark.parametrize("tests", ["", HEADER, f"# only a comment\n{HEADER}\n\n"],
                         ids=["no header", "header only", "comments and header"])
def test_empty_set_is_refused(tmp_path: Path, tests: str) -> None:
    folder = _write_set(tmp_path / "set", tests=tests)
    with pytest.raises(InputError) as error:
        load_measurement_set(folder)
    assert error.value.file == str(folder / TESTS_FILE)
    assert "no header" in error.value.message or "no tests" in error.value.message


SPREADSHEET_CASES = [
    ("byte-order mark", "\ufeff" + "\n".join([HEADER, *ROWS]) + "\n"),
    ("crlf line ends", "\r\n".join([HEADER, *ROWS]) + "\r\n"),
    ("extra columns", "\n".join([f"note,{HEADER},operator"]
                                + [f"x,{row},someone" for row in ROWS]) + "\n"),
]


@pytest.mark.parametrize("text", [c[1] for c in SPREADSHEET_CASES],
                         ids=[c[0] for c in SPREADSHEET_CASES])
def test_spreadsheet_csv_reads_like_the_plain_one(tmp_path: Path, text: str) -> None:
    plain = load_measurement_set(_write_set(tmp_path / "plain")).tests[0]
    folder = _write_set(tmp_path / "set")
    (folder / TESTS_FILE).write_bytes(text.encode("utf-8"))
    (test,) = load_measurement_set(folder).tests
    assert (test.test_id, test.mode, test.angle_deg) == ("a", "tension", 0.0)
    for name in ("time_s", "displacement_m", "force_n"):
        np.testing.assert_array_equal(getattr(test, name), getattr(plain, name))


@pytest.mark.parametrize("text", [c[1] for c in SPREADSHEET_CASES],
                         ids=[c[0] for c in SPREADSHEET_CASES])
def test_force_curve_reads_spreadsheet_csv(tmp_path: Path, text: str) -> None:
    from cell.tissue.forcecurve import ForceCurve

    path = tmp_path / "curve.csv"
    path.write_bytes(text.replace("force_N", "force_n")
                     .encode("utf-8"))
    curve = ForceCurve.from_csv(path)
    np.testing.assert_array_equal(curve.time_s, [0.0, 0.5, 1.0])
    np.testing.assert_array_equal(curve.force_n, [0.0, 0.01, 0.02])


def test_csv_errors_are_csv_errors_naming_line_and_column(tmp_path: Path) -> None:
    from cell.errors import CsvError
    from cell.io import read_csv

    path = tmp_path / "t.csv"
    path.write_text("\ufeffa,b\r\n1,2\r\n3,x\r\n")
    table = read_csv(path, ["b"])
    assert table.lines == (2, 3)
    with pytest.raises(CsvError) as error:
        table.numbers("b")
    assert (error.value.file, error.value.field) == (str(path), "line 3, column b")
