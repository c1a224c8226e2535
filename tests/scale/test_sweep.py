"""`musclecell sweep` without Ray (`--workers 1`): sweep files and their errors, the runs'
design, the results folder (table, plots, summary) and resuming; the batch diagnosis's
folder checks."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from cell.cli import main
from cell.errors import InputError, SweepError
from cell.scale.design import design
from cell.scale.pool import Workers
from cell.scale.spec import load_sweep
from cell.scale.sweep import prepare, run_sweep
from tests.paths import DEFAULT_SCENARIO, PROJECT_ROOT

EXAMPLE = PROJECT_ROOT / "scenarios" / "sweeps" / "binding_strength.toml"
#: Very short episodes on coarse tissue; a tissue speed limit no run can keep makes one
#: diverge at its first step.
SHORT = f"""
[sweep]
scenario = "{DEFAULT_SCENARIO.as_posix()}"
seed = 5

[overrides]
tissue.cell_size_m = 0.05
perception.enabled = false
end_s = 0.3

[variables]
aponeurosis.stiffness_n_m = [40.0, 80.0]
simulation.max_tissue_speed_m_s = [20.0, 1e-4]
"""


def write(folder: Path, text: str, name: str = "sweep.toml") -> Path:
    path = folder / name
    path.write_text(text)
    return path


def test_the_example_sweep_is_a_24_run_grid_on_coarse_tissue() -> None:
    tasks = prepare(load_sweep(EXAMPLE))
    assert len(tasks) == 24
    assert {t.scenario.tissue.cell_size_m for t in tasks} == {0.05}
    assert [t.scenario.seed for t in tasks] == list(range(24))
    pairs = {(t.scenario.aponeurosis.stiffness_n_m, t.scenario.cut.speed_m_s) for t in tasks}
    assert len(pairs) == 24


@pytest.mark.parametrize(("text", "key"), [
    ("[sweep]\nscenario = 'x.toml'\n[variabels]\na = [1]\n", "variabels"),
    ("[sweep]\nscenario = '{s}'\nsampling = 'sobol'\n[variables]\ncut.speed_m_s = [1.0]\n",
     "sweep.sampling"),
    ("[sweep]\n[variables]\ncut.speed_m_s = [0.01]\n", "sweep.scenario"),
    ("[sweep]\nscenario = '{s}'\n", "variables"),
    ("[sweep]\nscenario = '{s}'\n[variables]\ncut.speed = [0.01]\n", "variables.cut.speed"),
    ("[sweep]\nscenario = '{s}'\n[variables]\ncut.speed_m_s = [0.01, 'fast']\n",
     "variables.cut.speed_m_s"),
    ("[sweep]\nscenario = '{s}'\n[variables]\ncut.speed_m_s = [0.01, -0.02]\n",
     "variables.cut.speed_m_s"),
    ("[sweep]\nscenario = '{s}'\n[variables]\ncut.speed_m_s = 0.01\n",
     "variables.cut.speed_m_s"),
    ("[sweep]\nscenario = '{s}'\n[variables]\nknife_blade.x = [1.0]\n",
     "variables.knife_blade"),
    ("[sweep]\nscenario = '{s}'\n[overrides]\ntissue.cell_size_m = 'coarse'\n"
     "[variables]\ncut.speed_m_s = [0.01]\n", "overrides.tissue.cell_size_m"),
    ("[sweep]\nscenario = '{s}'\nsampling = 'random'\n[variables]\n"
     "cut.speed_m_s = {{ low = 0.01, high = 0.05 }}\n", "sweep.runs"),
    ("[sweep]\nscenario = '{s}'\nsampling = 'latin-hypercube'\nruns = 4\n[variables]\n"
     "cut.speed_m_s = {{ low = 0.05, high = 0.01 }}\n", "variables.cut.speed_m_s.high"),
    ("[sweep]\nscenario = '{s}'\nsampling = 'random'\nruns = 4\n[variables]\n"
     "cut.speed_m_s = [0.01, 0.02]\n", "variables.cut.speed_m_s"),
    ("[sweep]\nscenario = '{s}'\nruns = 4\n[variables]\ncut.speed_m_s = [0.01]\n",
     "sweep.runs"),
    ("[sweep]\nscenario = '{s}'\n[overrides]\ncut.speed_m_s = 0.01\n[variables]\n"
     "cut.speed_m_s = [0.01]\n", "variables.cut.speed_m_s"),
    ("[sweep]\nscenario = '{s}'\nrun = 'policy'\n[variables]\ncell_size_m = [0.05]\n",
     "policy"),
    ("[sweep]\nscenario = '{s}'\nseed = -1\n[variables]\ncut.speed_m_s = [0.01]\n",
     "sweep.seed"),
    ("[sweep]\nrun = 'policy'\nrecord = true\n[policy]\nenv = 'musclecell/Cut-v1'\n"
     "[variables]\ncell_size_m = [0.05]\n", "sweep.record"),
])
def test_a_bad_sweep_file_is_refused_naming_the_file_and_the_key(tmp_path: Path, text: str,
                                                                 key: str) -> None:
    path = write(tmp_path, text.format(s=DEFAULT_SCENARIO.as_posix()))
    with pytest.raises(SweepError) as error:
        prepare(load_sweep(path))
    assert (error.value.file, error.value.field) == (str(path), key)


def test_a_sweep_file_that_is_not_toml_names_the_file(tmp_path: Path) -> None:
    path = write(tmp_path, "[sweep\n")
    with pytest.raises(SweepError, match="not valid TOML") as error:
        load_sweep(path)
    assert error.value.file == str(path)


def test_the_cli_refuses_a_bad_sweep_before_any_run(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture) -> None:
    path = write(tmp_path, SHORT.replace("stiffness_n_m", "stifness_n_m"))
    assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--workers", "1"]) == 2
    assert f"{path}, variables.aponeurosis.stifness_n_m: unknown key" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_latin_hypercube_puts_one_run_in_each_stratum_and_follows_the_seed(
        tmp_path: Path) -> None:
    text = (f"[sweep]\nscenario = '{DEFAULT_SCENARIO.as_posix()}'\nsampling = "
            "'latin-hypercube'\nruns = 8\nseed = {seed}\n[variables]\n"
            "cut.speed_m_s = {{ low = 0.02, high = 0.06 }}\n"
            "aponeurosis.stiffness_n_m = {{ low = 10.0, high = 1000.0, log = true }}\n")
    points = design(load_sweep(write(tmp_path, text.format(seed=3))))
    speeds = np.array([p.values["cut.speed_m_s"] for p in points])
    stiffness = np.array([p.values["aponeurosis.stiffness_n_m"] for p in points])
    assert sorted(np.floor((speeds - 0.02) / 0.005).astype(int)) == list(range(8))
    assert sorted(np.floor(np.log10(stiffness / 10.0) / 0.25).astype(int)) == list(range(8))
    assert [p.seed for p in points] == list(range(3, 11))
    again = design(load_sweep(write(tmp_path, text.format(seed=3))))
    other = design(load_sweep(write(tmp_path, text.format(seed=4))))
    assert [p.values for p in again] == [p.values for p in points]
    assert [p.values for p in other] != [p.values for p in points]


def test_a_sweep_writes_its_table_plots_and_summary_and_resumes(tmp_path: Path) -> None:
    path = write(tmp_path, SHORT)
    out = tmp_path / "out"
    first = run_sweep(path, out, Workers(1), progress=False)
    assert (first.played, first.skipped) == (4, 0)
    table = pq.read_table(out / "results.parquet").to_pylist()
    assert [row["status"] for row in table] == ["ok", "diverged", "ok", "diverged"]
    assert [row["aponeurosis.stiffness_n_m"] for row in table] == [40.0, 40.0, 80.0, 80.0]
    assert [row["seed"] for row in table] == [5, 6, 7, 8]
    assert "simulation diverged" in table[1]["error"] and table[1]["released_fraction"] is None
    assert table[0]["sim_time_s"] == pytest.approx(0.3, abs=0.02)
    assert (out / "results.csv").read_text().splitlines()[0].startswith(
        "run,seed,aponeurosis.stiffness_n_m,simulation.max_tissue_speed_m_s,status,error")
    for name in ("aponeurosis.stiffness_n_m.png", "simulation.max_tissue_speed_m_s.png"):
        assert (out / name).read_bytes().startswith(b"\x89PNG")
    summary = (out / "summary.md").read_text()
    assert "4 runs: 2 finished, 2 diverged, 0 failed" in summary
    assert "- run 1 (aponeurosis.stiffness_n_m = 40.0" in summary

    again = run_sweep(path, out, Workers(1), progress=False)
    assert (again.played, again.skipped) == (0, 4)
    assert again.rows == first.rows
    retried = run_sweep(path, out, Workers(1), retry_failed=True, progress=False)
    assert (retried.played, retried.skipped) == (2, 2)
    changed = run_sweep(write(tmp_path, SHORT.replace("[40.0, 80.0]", "[40.0, 90.0]")), out,
                        Workers(1), progress=False)
    assert (changed.played, changed.skipped) == (2, 2)  # the runs of the changed value
    assert not list(out.rglob(".*.tmp"))


def test_without_ray_the_cli_says_how_to_install_it(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch,
                                                    capsys: pytest.CaptureFixture) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # what `import ray` meets when not installed
    path = write(tmp_path, SHORT)
    assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--workers", "2"]) == 2
    assert "pip install -e '.[scale]'" in capsys.readouterr().err


def test_workers_1_with_an_address_is_refused(tmp_path: Path,
                                              capsys: pytest.CaptureFixture) -> None:
    path = write(tmp_path, SHORT)
    assert main(["sweep", str(path), "--out", str(tmp_path / "o"), "--workers", "1",
                 "--address", "auto"]) == 2
    assert "--workers" in capsys.readouterr().err


def test_a_batch_needs_a_folder_of_sets(tmp_path: Path) -> None:
    from cell.scale.batch import set_folders

    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="no measurement set") as error:
        set_folders(tmp_path / "empty")
    assert error.value.file == str(tmp_path / "empty")


def test_a_policy_sweep_plays_one_env_episode_per_run(tmp_path: Path) -> None:
    path = write(tmp_path, "[sweep]\nrun = 'policy'\nseed = 100\n[policy]\n"
                 "env = 'musclecell/Cut-v1'\nname = 'scripted'\n[overrides]\ncell_size_m = 0.05\n"
                 "[variables]\ntime_limit_s = [0.3]\n")
    rows = run_sweep(path, tmp_path / "out", Workers(1), progress=False).rows
    assert [(row["status"], row["seed"], row["policy"]) for row in rows] == [
        ("ok", 100, "scripted")]
    assert rows[0]["elapsed_s"] == pytest.approx(0.3, abs=0.03)
    assert set(rows[0]) >= {"return", "success", "released_fraction", "torn_fraction"}


def test_a_policy_sweep_refuses_an_unknown_env_keyword(tmp_path: Path) -> None:
    path = write(tmp_path, "[sweep]\nrun = 'policy'\n[policy]\nenv = 'musclecell/Cut-v1'\n"
                 "[variables]\ncell_sise_m = [0.05]\n")
    with pytest.raises(SweepError, match="cell_sise_m") as error:
        prepare(load_sweep(path))
    assert (error.value.file, error.value.field) == (str(path), "variables")


@pytest.mark.slow  # diagnoses twice
def test_a_batch_diagnoses_every_set_records_a_broken_one_and_resumes(tmp_path: Path) -> None:
    from cell.diagnosis.engine.settings import DiagnosisParams
    from cell.scale.batch import diagnose_batch
    from cell.synthetic.specimen import write_hidden_effect_set

    write_hidden_effect_set(tmp_path / "sets" / "offset", 3, "force_offset")
    lines = (tmp_path / "sets" / "offset" / "tests.csv").read_text().splitlines()
    # Three of its tests: a small set, diagnosed in seconds.
    kept = [line for line in lines[1:] if line.split(",")[0] in ("t00", "c00", "t90")]
    (tmp_path / "sets" / "offset" / "tests.csv").write_text("\n".join([lines[0], *kept]))
    broken = tmp_path / "sets" / "broken"
    broken.mkdir()
    (broken / "specimen.toml").write_text("[specimen]\nname = 'b'\n")
    quick = DiagnosisParams(fit_samples=8, max_evaluations=10)
    out = tmp_path / "out"
    first = diagnose_batch(tmp_path / "sets", out, Workers(1), quick, progress=False)
    by_set = {row["set"]: row for row in first.rows}
    assert by_set["offset"]["status"] == "ok" and by_set["offset"]["causes"] == "force_offset"
    assert by_set["offset"]["gain"] > 0.5
    assert by_set["broken"]["status"] == "failed"
    assert "specimen.toml" in by_set["broken"]["error"]
    assert pq.read_table(out / "diagnoses.parquet").num_rows == 2
    assert (out / "sets" / "offset-material.toml").is_file()
    assert "| force_offset | 1 |" in (out / "summary.md").read_text()
    again = diagnose_batch(tmp_path / "sets", out, Workers(1), quick, progress=False)
    assert (again.played, again.skipped) == (0, 2)
