"""scripts/setup.sh installs through the virtual environment's real path.

The docs' snippets run in a folder whose ``.venv`` is a link to the project's; an install made
there must not write commands that name the link's python, which is gone with the folder.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# Stands in for the venv's python: logs how it was called; pip and the import checks succeed.
RECORDING_PYTHON = """#!/usr/bin/env bash
echo "$0 $*" >> "$(dirname "$0")/../calls.log"
"""


def test_an_install_through_a_linked_venv_runs_pip_as_the_real_venv(tmp_path: Path) -> None:
    real_venv = tmp_path / "real-venv"
    (real_venv / "bin").mkdir(parents=True)
    python = real_venv / "bin" / "python"
    python.write_text(RECORDING_PYTHON)
    python.chmod(0o755)
    (real_venv / "bin" / "activate").write_text("")
    project = tmp_path / "project"
    (project / "scripts").mkdir(parents=True)
    shutil.copy(ROOT / "scripts" / "setup.sh", project / "scripts" / "setup.sh")
    shutil.copy(ROOT / "pyproject.toml", project / "pyproject.toml")
    (project / ".venv").symlink_to(real_venv)
    # The Debian packages are not what this test is about: a dpkg that finds them all.
    fake_bin = tmp_path / "fake-bin"
    fake_bin.mkdir()
    (fake_bin / "dpkg").write_text("#!/usr/bin/env bash\nexit 0\n")
    (fake_bin / "dpkg").chmod(0o755)

    subprocess.run(
        ["bash", "-c", f'export PATH="{fake_bin}:$PATH"; source scripts/setup.sh'],
        cwd=project, check=True, capture_output=True, text=True, timeout=60,
    )

    calls = (real_venv / "calls.log").read_text().splitlines()
    pip_calls = [call for call in calls if " -m pip install " in call]
    assert any("-e .[" in call for call in pip_calls), calls
    assert all(call.startswith(f"{real_venv.resolve()}/bin/python ") for call in calls), calls
