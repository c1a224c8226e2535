"""Shear and biaxial tests and per-test specimens in a measurement set: what a lab writes reads
back as written, and every bad input names the file, line and column."""

from pathlib import Path

import numpy as np
import pytest

from cell.errors import InputError
from cell.measure.shearbiaxial import SHEAR_PLANES
from cell.measure.specimens import SPECIMEN_FILE, TESTS_FILE, load_measurement_set

SPECIMEN = """[specimen]
name = "round"
size_m = [0.010, 0.010, 0.010]
"""
HEADER = ("test_id,mode,angle_deg,time_s,displacement_m,force_N,shear_plane,normal_force_N,"
          "displacement_x_m,force_x_N,specimen,size_x_m,size_y_m,size_z_m")
UNIAXIAL = ["t,tension,0,{t},{d},{f},,,,,S1,,,"]
SHEAR = ["s,shear,,{t},{d},{f},sf,{n},,,S2,0.004,0.004,0.002"]
BIAXIAL = ["b,biaxial,90,{t},{d},{f},,,{dx},{fx},S1,,,"]


def _rows(templates: list[str], samples: int = 4) -> list[str]:
    values = {"d": 1e-4, "f": 0.01, "n": -0.002, "dx": 5e-5, "fx": 0.004}
    return [row.format(t=k, **{name: f"{v * k:g}" for name, v in values.items()})
            for k in range(samples) for row in templates]


GOOD = "\n".join([HEADER, *_rows(UNIAXIAL + SHEAR + BIAXIAL)])


def _write_set(folder: Path, tests: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / SPECIMEN_FILE).write_text(SPECIMEN)
    (folder / TESTS_FILE).write_text(tests + "\n")
    return folder


def test_shear_and_biaxial_rows_read_back_as_written(tmp_path: Path) -> None:
    data = load_measurement_set(_write_set(tmp_path / "set", GOOD))
    (uniaxial,), (shear,), (biaxial,) = data.tests, data.shear_tests, data.biaxial_tests
    k = np.arange(4.0)
    assert (uniaxial.test_id, uniaxial.specimen_id, uniaxial.size_m) == ("t", "S1", None)
    assert (shear.test_id, shear.shear_plane, shear.specimen_id) == ("s", "sf", "S2")
    assert shear.size_m == (0.004, 0.004, 0.002)
    assert shear.fibre_axis == 0  # sf: sheets normal to the plates, sheared along the fibres
    np.testing.assert_allclose(shear.gamma(shear.size_of(data.specimen)), 1e-4 * k / 0.002)
    np.testing.assert_allclose(shear.normal_force_n, -0.002 * k)
    assert (biaxial.test_id, biaxial.angle_deg, biaxial.specimen_id) == ("b", 90.0, "S1")
    np.testing.assert_allclose(biaxial.strains(biaxial.size_of(data.specimen)),
                               np.stack([1e-2 * k, 5e-3 * k], axis=1))
    np.testing.assert_allclose(biaxial.force_x_n, 0.004 * k)


def test_a_test_of_its_own_size_has_its_own_strain_and_stress(tmp_path: Path) -> None:
    sized = UNIAXIAL[0].replace("S1,,,", "S1,0.02,0.005,0.004")
    data = load_measurement_set(_write_set(tmp_path / "set", "\n".join([HEADER,
                                                                        *_rows([sized])])))
    test = data.tests[0]
    assert test.size_m == (0.02, 0.005, 0.004)
    assert test.strain(data.specimen)[-1] == pytest.approx(3e-4 / 0.004)
    assert test.stress_pa(data.specimen)[-1] == pytest.approx(0.03 / 1e-4)


def test_shear_tests_without_a_normal_force_or_specimen_columns_read(tmp_path: Path) -> None:
    header = "test_id,mode,time_s,displacement_m,force_N,shear_plane"
    rows = [f"s,shear,{k},{1e-4 * k:g},{0.01 * k:g},ns" for k in range(3)]
    folder = _write_set(tmp_path / "set", "\n".join([header, *rows]))
    (shear,) = load_measurement_set(folder).shear_tests
    assert shear.normal_force_n is None and shear.size_m is None and shear.specimen_id == ""
    assert shear.fibre_axis == 1


def _good_with(old: str, new: str, count: int = 1) -> str:
    assert old in GOOD
    return GOOD.replace(old, new, count)


# (name, tests.csv, field expected in the error, words expected in the message); the shear
# test's rows are lines 3, 6, 9, 12 and the biaxial test's 4, 7, 10, 13.
CASES = [
    ("unknown shear plane", _good_with(",sf,", ",fx,", 4), "line 3, column shear_plane",
     "unknown shear plane 'fx'"),
    ("shear plane changes", _good_with("3,0.0003,0.03,sf", "3,0.0003,0.03,fs"),
     "line 12, column shear_plane", "changes shear_plane from 'sf' to 'fs'"),
    ("angle on a shear test", _good_with("s,shear,,", "s,shear,45,"),
     "line 3, column angle_deg", "leave angle_deg empty"),
    ("normal force on some samples", _good_with("sf,-0.002,", "sf,,"),
     "line 6, column normal_force_N", "normal force on other samples"),
    ("biaxial angle changes", _good_with("b,biaxial,90,3", "b,biaxial,0,3"),
     "line 13, column angle_deg", "changes angle_deg from 90 deg to 0 deg"),
    ("biaxial force not a number", _good_with(",0.008,S1", ",heavy,S1"),
     "line 10, column force_x_N", "not a number"),
    ("specimen changes", _good_with("0.0003,0.03,,,,,S1", "0.0003,0.03,,,,,S9"),
     "line 11, column specimen", "more than one specimen"),
    ("size given in part", _good_with("S2,0.004,0.004,0.002", "S2,0.004,0.004,"),
     "line 3, column size_z_m", "all of size_x_m, size_y_m, size_z_m"),
    ("size in mm", _good_with("S2,0.004,0.004,0.002", "S2,40,40,20", 4),
     "line 3, column size_x_m", None),
    ("shear mode changes", _good_with("s,shear,,3", "s,tension,,3"),
     "line 12, column mode", "changes mode from 'shear' to 'tension'"),
    ("implausible stress", _good_with(",0.03,sf", ",20000,sf"),
     "test s, column force_N", "as stress on the 1.6e-05 m^2"),
]


@pytest.mark.parametrize(("tests", "field", "words"), [c[1:] for c in CASES],
                         ids=[c[0] for c in CASES])
def test_bad_shear_or_biaxial_rows_name_file_line_and_column(
        tmp_path: Path, tests: str, field: str, words: str | None) -> None:
    folder = _write_set(tmp_path / "set", tests)
    with pytest.raises(InputError) as error:
        load_measurement_set(folder)
    assert error.value.file == str(folder / TESTS_FILE)
    assert error.value.field == field
    assert words is None or words in error.value.message


@pytest.mark.parametrize("column", ["shear_plane", "force_x_N"])
def test_a_missing_column_of_a_mode_the_set_holds_is_named(tmp_path: Path, column: str) -> None:
    names = HEADER.split(",")
    at = names.index(column)
    lines = [",".join(c for i, c in enumerate(line.split(",")) if i != at)
             for line in GOOD.splitlines()]
    folder = _write_set(tmp_path / "set", "\n".join(lines))
    with pytest.raises(InputError, match=f"column {column}: missing column"):
        load_measurement_set(folder)


def test_every_shear_plane_reads(tmp_path: Path) -> None:
    rows = [row.replace(",sf,", f",{plane},").replace("s,shear", f"{plane},shear")
            for plane in SHEAR_PLANES for row in _rows(SHEAR)]
    data = load_measurement_set(_write_set(tmp_path / "set", "\n".join([HEADER, *rows])))
    assert [t.shear_plane for t in data.shear_tests] == list(SHEAR_PLANES)
    assert [t.fibre_axis for t in data.shear_tests] == [2, 2, 0, 1, 0, 1]
