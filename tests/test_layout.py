"""The house: every package imports only the layers below it, modules and functions stay small,
the diagnosis side runs without MuJoCo, and the package ships every sub-package."""

import subprocess
import sys
import tomllib
from pathlib import Path

from tests.layout_rules import import_violations, size_violations
from tests.paths import PROJECT_ROOT


def test_no_package_imports_above_its_layer() -> None:
    assert [str(v) for v in import_violations(PROJECT_ROOT)] == []


def test_an_upward_import_is_caught(tmp_path: Path) -> None:
    for top in ("cell", "controllers", "envs"):
        (tmp_path / top).mkdir()
    (tmp_path / "cell" / "tissue").mkdir()
    (tmp_path / "cell" / "tissue" / "geometry.py").write_text(
        "from cell.sim.episode import Episode\nfrom cell.errors import MeshError\n")
    (tmp_path / "cell" / "rheology").mkdir()
    (tmp_path / "cell" / "rheology" / "diagnosis.py").write_text(
        "from cell.rheology import synthetic\nfrom cell.tissue import massspring\n")
    (tmp_path / "controllers" / "knife.py").write_text("import envs\nimport tests.paths\n")
    found = sorted(str(v) for v in import_violations(tmp_path))
    assert found == [
        "cell/rheology/diagnosis.py:1: cell.rheology.diagnosis must not import "
        "cell.rheology.synthetic",
        "cell/rheology/diagnosis.py:2: cell.rheology.diagnosis (cell.rheology) imports "
        "cell.tissue.massspring",
        "cell/tissue/geometry.py:1: cell.tissue.geometry (cell.tissue) imports cell.sim.episode",
        "cell/tissue/geometry.py:1: cell.tissue.geometry (cell.tissue) imports "
        "cell.sim.episode.Episode",
        "controllers/knife.py:1: controllers.knife (controllers) imports envs",
        "controllers/knife.py:2: the library imports tests.paths",
    ]


def test_modules_and_functions_stay_small() -> None:
    assert [str(v) for v in size_violations(PROJECT_ROOT)] == []


def test_the_diagnosis_side_does_not_load_mujoco() -> None:
    code = ("import sys, cell.rheology.diagnosis, cell.rheology.report, cell.rheology.synthetic;"
            "print('mujoco' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=PROJECT_ROOT)
    assert out.stdout.strip() == "False"


def test_the_distribution_lists_every_package() -> None:
    listed = set(tomllib.loads((PROJECT_ROOT / "pyproject.toml").read_text())
                 ["tool"]["setuptools"]["packages"])
    on_disk = {".".join(p.parent.relative_to(PROJECT_ROOT).parts)
               for top in ("cell", "controllers", "envs")
               for p in (PROJECT_ROOT / top).rglob("__init__.py")}
    assert on_disk | {"cell.assets"} == listed
