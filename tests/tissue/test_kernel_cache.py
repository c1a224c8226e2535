"""numba's on-disk cache never runs a stale spring law: after the law's source changes, every
cached kernel that calls it (the muscles', the specimen's) runs the new law.

numba stamps a cached kernel with its own source file only; the law and all its callers share
one file (:mod:`cell.tissue.springlaw`), so changing the law changes that stamp. The test
compiles a copy of the module with the cache on, edits the law in the copy, and runs the
kernels again in a fresh process on the same cache.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.paths import PROJECT_ROOT

_DRIVER = """
import json
import numpy as np
import springlaw
from cell.tissue.material import MassSpringMaterial
from cell.tissue.packedlaw import SpringLaw

law = SpringLaw.of(MassSpringMaterial.isotropic(3e4))
stress, _, _ = springlaw.spring_stress(0.1, 1.0, law.curves, law.params, law.history(1), 0, 0.0,
                                    True)
# One spring along x between a pinned vertex and a free one stretched by 10%.
qfrc = np.zeros(3)
springlaw.muscle_forces(
    np.array([0.1, 0.0, 0.0]), np.zeros(3), qfrc, np.array([-1, 0]), np.array([-1, 0]),
    np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), np.array([[0, 1]]), np.array([1.0]),
    np.array([1.0]), np.array([1.0]), law.curves, law.params, law.history(1), 0.0, 0.0,
    np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((0, 6)), False)
# The specimen's lattice: one spring along each axis, stretched 10% along z, x and y free.
tau = np.zeros((2, 4))
failed = springlaw.homogeneous_stress(
    np.array([0.0, 1.0]), np.array([[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.1, 0.0]]),
    np.array([0, 1, 3]), np.eye(3), np.ones(3), np.array([0.0, 0.0, 1.0]), law.curves,
    law.params, law.history(3), tau, np.zeros((2, 4)))
print(json.dumps([stress, -qfrc[0], tau[1, 2], failed]))
"""


def _run(folder: Path) -> list[float]:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(folder / "cache"),
           "PYTHONPATH": os.pathsep.join([str(folder), str(PROJECT_ROOT)])}
    out = subprocess.run([sys.executable, "-c", _DRIVER], capture_output=True, text=True,
                         cwd=folder, env=env, check=True, timeout=600)
    return json.loads(out.stdout)


@pytest.mark.slow
def test_a_changed_law_reaches_every_cached_kernel(tmp_path: Path) -> None:
    module = tmp_path / "springlaw.py"
    shutil.copy(PROJECT_ROOT / "cell" / "tissue" / "springlaw.py", module)
    before = _run(tmp_path)
    assert before[3] == -1 and before[0] == pytest.approx(3000.0)
    assert before[1] == pytest.approx(before[0]) and before[2] > 0.0
    assert list((tmp_path / "cache").rglob("*.nbi")), "the kernels were not cached"
    source = module.read_text()
    law = "    stress = modulus * elastic / (1.0 + params[PARAM_GEOMETRY] * x)\n"
    assert law in source
    module.write_text(source.replace(law, law.replace("stress = ", "stress = 2.0 * ")))
    after = _run(tmp_path)
    assert after[3] == -1
    assert after[:3] == pytest.approx([2.0 * value for value in before[:3]], rel=1e-9)
