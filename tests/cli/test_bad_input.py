"""Issue 32's bad inputs, through the command line as a user meets them: a file that is not text,
a folder where a file is expected, absurd numbers, messages that name the wrong key. Each
exits 2 naming the file and the key, prints no traceback, and leaves the working folder (the
output folder in it) as it was.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.paths import DEFAULT_SCENARIO, EXAMPLE_SET
from tests.refusals import refused

JUNK = bytes(range(256)) * 4
#: A valid scenario's first line, then binary junk: what a truncated download or a wrong
#: file looks like.
SCENARIO_THEN_JUNK = b"[scenario]\nname = 'x'\n" + JUNK


@pytest.fixture()
def cwd(tmp_path: Path) -> Path:
    """A working folder with a copy of the example set and an output folder that holds a
    file (which must stay as it was)."""
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "kept.txt").write_text("from before\n")
    good = tmp_path / "set"
    good.mkdir()
    for name in ("specimen.toml", "tests.csv"):
        (good / name).write_bytes((EXAMPLE_SET / name).read_bytes())
    return tmp_path


# -- issue 32, item 2: not text, or a folder where a file is expected -----------------------

def test_a_binary_scenario(cwd: Path) -> None:
    (cwd / "junk.toml").write_bytes(SCENARIO_THEN_JUNK)
    refused(cwd, "plan", "junk.toml", "--out", "out/plan.json",
            words=("junk.toml", "not UTF-8 text"))


def test_a_folder_as_scenario(cwd: Path) -> None:
    (cwd / "scenario.toml").mkdir()
    refused(cwd, "run", "scenario.toml", "--out", "out/summary.json",
            words=("scenario.toml", "a folder, not a file"))


def test_a_binary_material_file(cwd: Path) -> None:
    (cwd / "meat.toml").write_bytes(JUNK)
    (cwd / "s.toml").write_text('[material]\nfile = "meat.toml"\n')
    refused(cwd, "export-mjcf", "s.toml", "--out", "out/scene.xml",
            words=("meat.toml", "not UTF-8"))


def test_a_binary_sweep_file(cwd: Path) -> None:
    (cwd / "sweep.toml").write_bytes(JUNK)
    refused(cwd, "sweep", "sweep.toml", "--out", "out/sweep", "--workers", "1",
            words=("sweep.toml", "not UTF-8 text"))


def test_a_binary_specimen_file(cwd: Path) -> None:
    (cwd / "set" / "specimen.toml").write_bytes(JUNK)
    refused(cwd, "diagnose", "set", "--out", "out/d.json", words=("specimen.toml", "not UTF-8"))


def test_a_folder_as_tests_file(cwd: Path) -> None:
    (cwd / "set" / "tests.csv").unlink()
    (cwd / "set" / "tests.csv").mkdir()
    refused(cwd, "diagnose", "set", "--out", "out/d.json", words=("tests.csv", "a folder"))


def test_a_file_as_set_folder(cwd: Path) -> None:
    (cwd / "notaset").write_text("hello\n")
    refused(cwd, "diagnose", "notaset", "--out", "out/d.json", words=("notaset", "not a folder"))


# -- issue 32, item 3: absurd numbers -------------------------------------------------------

def test_forces_of_1e308_are_refused_naming_file_and_column(cwd: Path) -> None:
    lines = (cwd / "set" / "tests.csv").read_text().splitlines()
    header = lines[0].split(",")
    force = header.index("force_N")
    rows = [line.split(",") for line in lines[1:]]
    for row in rows:
        row[force] = "1e308"
    (cwd / "set" / "tests.csv").write_text("\n".join(",".join(r) for r in [header, *rows]))
    refused(cwd, "diagnose", "set", "--out", "out/d.json",
            words=("tests.csv", "column force_N", "not plausible"))


def test_a_set_of_zero_forces_is_refused_before_a_fit_makes_a_material_of_1e_5_pa(
        cwd: Path) -> None:
    lines = (cwd / "set" / "tests.csv").read_text().splitlines()
    force = lines[0].split(",").index("force_N")
    rows = [line.split(",") for line in lines[1:]]
    for row in rows:
        row[force] = "0.0"
    (cwd / "set" / "tests.csv").write_text("\n".join([lines[0], *(",".join(r) for r in rows)]))
    refused(cwd, "diagnose", "set", "--out", "out/d.json",
            words=("tests.csv", "column force_N", "measured nothing"))


def test_a_material_of_1e_5_pa_is_refused_naming_the_key(cwd: Path) -> None:
    (cwd / "s.toml").write_text('[material]\nmodel = "mass_spring"\n'
                                "[material.longitudinal]\nmodulus_pa = 1e-5\n"
                                "[material.transverse]\nmodulus_pa = 6e3\n")
    refused(cwd, "export-mjcf", "s.toml", "--out", "out/scene.xml",
            words=("s.toml", "material.longitudinal.modulus_pa", "not plausible"))


def test_a_specimen_beyond_the_cell_is_refused(cwd: Path) -> None:
    (cwd / "set" / "specimen.toml").write_text(
        '[specimen]\nname = "slab"\nsize_m = [0.01, 0.01, 1e6]\n')
    refused(cwd, "diagnose", "set", "--out", "out/d.json",
            words=("specimen.toml", "specimen.size_m", "not plausible"))


# -- issue 32, item 5: messages name the key that is wrong ----------------------------------

def test_a_specimen_without_size_names_the_key(cwd: Path) -> None:
    (cwd / "set" / "specimen.toml").write_text('[specimen]\nname = "cube"\n')
    message = refused(cwd, "diagnose", "set", "--out", "out/d.json",
                      words=("specimen.toml", "specimen.size_m", "missing key"))
    assert "__init__" not in message


def test_a_tiny_shape_names_the_key_that_makes_it_too_small(cwd: Path) -> None:
    (cwd / "s.toml").write_text("[tissue]\nlength_m = 0.045\nround_width_m = 0.013\n"
                                "shank_width_m = 0.011\nround_height_m = 0.01\n"
                                "shank_height_m = 0.009\nvalley_depth_m = 0.0015\n"
                                "edge_radius_m = 0.005\ncell_size_m = 0.0025\n")
    message = refused(cwd, "plan", "s.toml", "--out", "out/plan.json",
                      words=("s.toml", "tissue.round_width_m", "not plausible"))
    assert "marker" not in message


def test_a_huge_cell_size_names_the_cell_size(cwd: Path) -> None:
    (cwd / "s.toml").write_text("[tissue]\ncell_size_m = 0.5\n")
    message = refused(cwd, "plan", "s.toml", "--out", "out/plan.json",
                      words=("s.toml", "tissue.cell_size_m", "coarser"))
    assert "concave" not in message


def test_a_sweep_of_the_timestep_names_the_timestep(cwd: Path) -> None:
    (cwd / "sweep.toml").write_text(f'[sweep]\nscenario = "{DEFAULT_SCENARIO.as_posix()}"\n'
                                    "[variables]\nsimulation.timestep_s = [0.005, 0.05]\n")
    refused(cwd, "sweep", "sweep.toml", "--out", "out/sweep", "--workers", "1",
            words=("sweep.toml", "variables.simulation.timestep_s"))


def test_a_hyper_parameter_of_the_wrong_type_names_it(cwd: Path) -> None:
    pytest.importorskip("stable_baselines3")
    refused(cwd, "learn", "Cut-v1", "--steps", "64", "--out", "out/learn",
            "--hyper", '{"n_steps": "many"}', words=("hyper.n_steps", "expected an integer"))


def test_a_corrupt_policy_is_named(cwd: Path) -> None:
    pytest.importorskip("stable_baselines3")
    run = cwd / "run"
    run.mkdir()
    (run / "policy.zip").write_bytes(JUNK)
    (run / "vecnormalize.pkl").write_bytes(JUNK)
    refused(cwd, "evaluate", "run", "Cut-v1", "--episodes", "1", "--out", "out/eval",
            words=("policy.zip",))


def test_a_policy_of_another_name_is_named(cwd: Path) -> None:
    pytest.importorskip("stable_baselines3")
    (cwd / "junk.zip").write_bytes(JUNK)
    refused(cwd, "evaluate", "junk.zip", "Cut-v1", "--episodes", "1", "--out", "out/eval",
            words=("junk.zip",))



# -- issue 32, item 2: a batch keeps going ---------------------------------------------------

def test_a_batch_records_unreadable_sets_and_diagnoses_the_good_one(tmp_path: Path) -> None:
    from cell.diagnosis.engine.settings import DiagnosisParams
    from cell.scale.batch import diagnose_batch
    from cell.scale.pool import Workers
    from cell.synthetic.specimen import write_hidden_effect_set

    sets = tmp_path / "sets"
    write_hidden_effect_set(sets / "good", 3, "force_offset")
    lines = (sets / "good" / "tests.csv").read_text().splitlines()
    kept = [line for line in lines[1:] if line.split(",")[0] in ("t00", "c00", "t90")]
    (sets / "good" / "tests.csv").write_text("\n".join([lines[0], *kept]))  # seconds, not minutes
    # Bad sets: a binary specimen file, a specimen file that is a folder, a huge specimen;
    # the tests file of each is a folder.
    for name, specimen in (("binary", JUNK), ("folders", None),
                           ("huge", b"[specimen]\nname = 'h'\nsize_m = [1e6, 1, 1]\n")):
        folder = sets / name
        (folder / "tests.csv").mkdir(parents=True)
        if specimen is None:
            (folder / "specimen.toml").mkdir()
        else:
            (folder / "specimen.toml").write_bytes(specimen)
    outcome = diagnose_batch(sets, tmp_path / "out", Workers(1),
                             DiagnosisParams(fit_samples=8, max_evaluations=10), progress=False)
    rows = {row["set"]: row for row in outcome.rows}
    assert rows["good"]["status"] == "ok"
    assert "specimen.toml: not UTF-8 text" in rows["binary"]["error"]
    assert "specimen.toml: a folder, not a file" in rows["folders"]["error"]
    assert "specimen.size_m" in rows["huge"]["error"]
    assert all(rows[name]["status"] == "failed" for name in ("binary", "folders", "huge"))


def test_a_set_of_one_test_names_its_test(cwd: Path) -> None:
    """Each test is held out in turn, so one test of a kind leaves nothing to predict it."""
    rows = (cwd / "set" / "tests.csv").read_text().splitlines()
    kept = [rows[0], *(row for row in rows[1:] if row.startswith("t00,"))]
    (cwd / "set" / "tests.csv").write_text("\n".join(kept) + "\n")
    refused(cwd, "diagnose", "set", "--out", "out/d.json",
            words=("tests.csv", "test_id", "t00", "at least two"))
