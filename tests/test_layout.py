"""The house: every package imports only the layers below it, no module imports itself back
through others, modules and functions stay small, the diagnosis side runs without MuJoCo, and
the package ships every sub-package."""

import subprocess
import sys
import tomllib
from pathlib import Path

from tests.layout_rules import import_cycles, import_violations, size_violations
from tests.paths import PROJECT_ROOT


def test_no_package_imports_above_its_layer() -> None:
    assert [str(v) for v in import_violations(PROJECT_ROOT)] == []


def test_an_upward_import_is_caught(tmp_path: Path) -> None:
    for top in ("cell", "controllers", "envs"):
        (tmp_path / top).mkdir()
    (tmp_path / "cell" / "tissue").mkdir()
    (tmp_path / "cell" / "tissue" / "geometry.py").write_text(
        "from cell.sim.episode import Episode\nfrom cell.errors import MeshError\n")
    (tmp_path / "cell" / "diagnosis" / "cut").mkdir(parents=True)
    (tmp_path / "cell" / "diagnosis" / "cut" / "new_cause.py").write_text(
        "from cell.synthetic import cut\nfrom cell.tissue import massspring\n")
    (tmp_path / "controllers" / "knife.py").write_text("import envs\nimport tests.paths\n")
    found = sorted(str(v) for v in import_violations(tmp_path))
    assert found == [
        "cell/diagnosis/cut/new_cause.py:1: cell.diagnosis.cut.new_cause must not import "
        "cell.synthetic",
        "cell/diagnosis/cut/new_cause.py:1: cell.diagnosis.cut.new_cause must not import "
        "cell.synthetic.cut",
        "cell/diagnosis/cut/new_cause.py:2: cell.diagnosis.cut.new_cause (cell.diagnosis) "
        "imports cell.tissue.massspring",
        "cell/tissue/geometry.py:1: cell.tissue.geometry (cell.tissue) imports cell.sim.episode",
        "cell/tissue/geometry.py:1: cell.tissue.geometry (cell.tissue) imports "
        "cell.sim.episode.Episode",
        "controllers/knife.py:1: controllers.knife (controllers) imports envs",
        "controllers/knife.py:2: the library imports tests.paths",
    ]


def test_the_engine_knows_no_family_of_causes(tmp_path: Path) -> None:
    engine = tmp_path / "cell" / "diagnosis" / "engine"
    engine.mkdir(parents=True)
    (engine / "new_rule.py").write_text(
        "from cell.diagnosis.specimen.causes import CAUSES\n"
        "from cell.diagnosis.engine.statistics import bic\n")
    (tmp_path / "cell" / "diagnosis" / "cut").mkdir()
    (tmp_path / "cell" / "diagnosis" / "cut" / "search.py").write_text(
        "from cell.diagnosis.engine.search import Search\n")
    assert sorted(str(v) for v in import_violations(tmp_path)) == [
        "cell/diagnosis/engine/new_rule.py:1: cell.diagnosis.engine.new_rule "
        "(cell.diagnosis.engine) imports cell.diagnosis.specimen.causes",
        "cell/diagnosis/engine/new_rule.py:1: cell.diagnosis.engine.new_rule "
        "(cell.diagnosis.engine) imports cell.diagnosis.specimen.causes.CAUSES",
    ]


def test_no_import_circle() -> None:
    assert [str(v) for v in import_cycles(PROJECT_ROOT)] == []


def test_an_import_circle_is_caught(tmp_path: Path) -> None:
    """Circles hidden in a function or under ``TYPE_CHECKING`` count, inside a sub-package
    and across packages; a package's ``__init__`` importing its own modules does not."""
    files = {
        "cell/__init__.py": "",
        "cell/diagnosis/__init__.py": "",
        "cell/diagnosis/specimen/diagnosis.py": "from cell.diagnosis.engine.search import Search\n",
        "cell/diagnosis/engine/search.py": ("from typing import TYPE_CHECKING\n"
                                            "from . import acceptance\n"),
        "cell/diagnosis/engine/acceptance.py": (
            "from typing import TYPE_CHECKING\n"
            "if TYPE_CHECKING:\n"
            "    from cell.diagnosis.specimen.diagnosis import Params\n"),
        "cell/sim/__init__.py": "",
        "cell/sim/episode.py": "def run():\n    import controllers.knife\n",
        "controllers/__init__.py": "",
        "controllers/knife.py": "from cell.sim import episode\n",
        "envs/__init__.py": "from envs.separation import SeparationEnv\n",
        "envs/separation.py": "import envs.params\nclass SeparationEnv: ...\n",
        "envs/params.py": "",
    }
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    assert sorted(str(v) for v in import_cycles(tmp_path)) == [
        "cell/diagnosis/engine/acceptance.py:3: import circle: cell.diagnosis.engine.acceptance"
        " -> cell.diagnosis.specimen.diagnosis -> cell.diagnosis.engine.search"
        " -> cell.diagnosis.engine.acceptance",
        "cell/sim/episode.py:2: import circle: cell.sim.episode -> controllers.knife -> "
        "cell.sim.episode",
    ]


def test_modules_and_functions_stay_small() -> None:
    assert [str(v) for v in size_violations(PROJECT_ROOT)] == []


def _loads(modules: str, heavy: str) -> bool:
    """Whether importing ``modules`` (comma-separated) in a fresh process loads ``heavy``."""
    code = f"import sys, {modules}; print({heavy!r} in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=PROJECT_ROOT)
    return out.stdout.strip() == "True"


def test_the_diagnosis_side_does_not_load_mujoco() -> None:
    assert not _loads("cell.diagnosis.sets, cell.diagnosis.specimen.report, "
                      "cell.diagnosis.cut.report, cell.measure.logs, cell.synthetic.specimen",
                      "mujoco")


def test_an_episode_starts_without_loading_trimesh() -> None:
    assert not _loads("cell.cli, cell.sim.episode", "trimesh")


def test_the_distribution_lists_every_package() -> None:
    listed = set(tomllib.loads((PROJECT_ROOT / "pyproject.toml").read_text())
                 ["tool"]["setuptools"]["packages"])
    on_disk = {".".join(p.parent.relative_to(PROJECT_ROOT).parts)
               for top in ("cell", "controllers", "envs")
               for p in (PROJECT_ROOT / top).rglob("__init__.py")}
    data = {".".join(("cell", *p.parent.relative_to(PROJECT_ROOT).parts))
            for top in ("assets", "scenarios") for p in (PROJECT_ROOT / top).rglob("*")
            if p.is_file() and "__pycache__" not in p.parts}
    assert on_disk | data == listed
