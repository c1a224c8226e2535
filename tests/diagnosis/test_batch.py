"""`musclecell diagnose --batch` diagnoses every kind of set that one-set `diagnose` takes
(uniaxial tests, cut tests, both), each into the files that command writes; a batch or a
sweep with rows that failed exits 4 once its table is written whole."""

from __future__ import annotations

import shutil
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from cell.cli import main
from tests.paths import PROJECT_ROOT

CUT_EXAMPLE = PROJECT_ROOT / "assets" / "measured" / "beef_cut_example"
#: The tests kept of the generated uniaxial set and of the cut example: small sets, each
#: diagnosed in seconds.
UNIAXIAL_KEPT = ("t00", "c00", "t90")
CUT_KEPT = ("c00", "c01", "c06", "c07")


def _kept_rows(path: Path, kept: tuple[str, ...]) -> tuple[str, list[str]]:
    """The header of the tests file at ``path`` and its rows of the tests ``kept``."""
    header, *rows = path.read_text().splitlines()
    return header, [row for row in rows if row.split(",")[0] in kept]


def write_sets(parent: Path) -> None:
    """A set of uniaxial tests, one of cut tests and one of both kinds, in ``parent``."""
    from cell.synthetic.specimen import write_hidden_effect_set

    uniaxial = parent / "uniaxial"
    write_hidden_effect_set(uniaxial, 3, "force_offset")
    header, rows = _kept_rows(uniaxial / "tests.csv", UNIAXIAL_KEPT)
    (uniaxial / "tests.csv").write_text("\n".join([header, *rows]) + "\n")

    cut = parent / "cut"
    shutil.copytree(CUT_EXAMPLE, cut)
    cut_header, cut_rows = _kept_rows(cut / "tests.csv", CUT_KEPT)
    (cut / "tests.csv").write_text("\n".join([cut_header, *cut_rows]) + "\n")

    # Both kinds: the uniaxial set's rows, then the cut tests' under other ids, each row
    # leaving the other kind's columns empty.
    mixed = parent / "mixed"
    mixed.mkdir()
    cut_specimen = (cut / "specimen.toml").read_text()
    (mixed / "specimen.toml").write_text((uniaxial / "specimen.toml").read_text() + "\n"
                                         + cut_specimen[cut_specimen.index("[block]"):])
    cut_columns = cut_header.split(",")[3:]  # after test_id, mode, time_s: edge and force
    lines = [f"{header},{','.join(cut_columns)}",
             *(row + "," * len(cut_columns) for row in rows)]
    for row in cut_rows[::2]:  # two cut tests: c00 and c06, a press and a sawing cut
        test_id, mode, time_s, *values = row.split(",")
        lines.append(",".join([f"cut-{test_id}", mode, "", time_s, "", "", *values]))
    (mixed / "tests.csv").write_text("\n".join(lines) + "\n")


@pytest.mark.slow  # three diagnoses twice; the default run's batch: tests/cli/test_bad_input.py
def test_a_batch_of_every_kind_of_set_matches_one_set_diagnose_and_fails_on_a_broken_set(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    sets, out = tmp_path / "sets", tmp_path / "out"
    write_sets(sets)
    assert main(["diagnose", "--batch", str(sets), "--out", str(out), "--workers", "1",
                 "--quiet"]) == 0
    rows = {row["set"]: row for row in pq.read_table(out / "diagnoses.parquet").to_pylist()}
    assert {name: (row["status"], row["tests"]) for name, row in rows.items()} == {
        "cut": ("ok", "cut"), "mixed": ("ok", "uniaxial cut"), "uniaxial": ("ok", "uniaxial")}
    assert rows["uniaxial"]["gain"] > 0.5 and rows["uniaxial"]["cut_gain"] is None
    assert rows["cut"]["gain"] is None and rows["cut"]["cut_gain"] > 0.5
    assert rows["mixed"]["gain"] == rows["uniaxial"]["gain"]
    assert "| mixed | uniaxial, cut |" in (out / "summary.md").read_text()
    for name in rows:
        one = tmp_path / "one" / f"{name}.json"
        assert main(["diagnose", str(sets / name), "--json", str(one), "--workers", "1"]) == 0
        assert (out / "sets" / f"{name}.json").read_text() == one.read_text()
        assert ((out / "sets" / f"{name}-material.toml").read_text()
                == one.with_name(f"{name}-material.toml").read_text())
    capsys.readouterr()

    # A set of one uniaxial test is read, but leaves no test held out to diagnose it by.
    broken = sets / "one-test"
    broken.mkdir()
    shutil.copy(sets / "uniaxial" / "specimen.toml", broken)
    header, rows_of_t00 = _kept_rows(sets / "uniaxial" / "tests.csv", ("t00",))
    (broken / "tests.csv").write_text("\n".join([header, *rows_of_t00]) + "\n")
    assert main(["diagnose", "--batch", str(sets), "--out", str(out), "--workers", "1",
                 "--quiet"]) == 4
    printed = capsys.readouterr()
    assert "4 sets (1 diagnosed now, 3 found done" in printed.out
    assert "1 of 4 sets failed" in printed.err
    table = {row["set"]: row for row in pq.read_table(out / "diagnoses.parquet").to_pylist()}
    assert [table[name]["status"] for name in sorted(table)] == ["ok", "ok", "failed", "ok"]
    assert table["one-test"]["error"].startswith("DiagnosisError: ")
    assert "tests.csv" in table["one-test"]["error"]
    assert "| one-test | | | | | DiagnosisError: " in (out / "summary.md").read_text()
    assert len((out / "diagnoses.csv").read_text().splitlines()) == 5


def test_a_sweep_with_a_failed_run_exits_4_with_its_table_written(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    # The sweep builds one env to check the keywords; a value that the env refuses fails
    # its own run only.
    path = tmp_path / "sweep.toml"
    path.write_text("[sweep]\nrun = 'policy'\nseed = 100\n[policy]\n"
                    "env = 'musclecell/Cut-v2'\nname = 'scripted'\n[overrides]\n"
                    "cell_size_m = 0.05\n[variables]\ntime_limit_s = [0.3, -1.0]\n")
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out), "--workers", "1", "--quiet"]) == 4
    assert "1 of 2 runs failed" in capsys.readouterr().err
    rows = pq.read_table(out / "results.parquet").to_pylist()
    assert [row["status"] for row in rows] == ["ok", "failed"]
    assert "time_limit_s" in rows[1]["error"]
    assert "2 runs: 1 finished, 0 diverged, 1 failed" in (out / "summary.md").read_text()
