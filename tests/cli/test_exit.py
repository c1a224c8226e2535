"""A process that used the native libraries the suite uses exits cleanly (issue 53: one full
run in nine ended in a segmentation fault at interpreter exit, after every test had passed).

Each check runs the sequence in a fresh interpreter under faulthandler, so that a crash in its
teardown shows as a non-zero exit status and a fatal-error report instead of passing unseen.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tests.paths import PROJECT_ROOT

ROOT = PROJECT_ROOT

#: A scene of one camera over a box, put forward: what each sequence below draws.
SCENE = """
import mujoco

spec = mujoco.MjSpec()
spec.worldbody.add_camera(name="eye", pos=[0.0, 0.0, 1.0])
spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[1.0, 1.0, 0.01])
model = spec.compile()
data = mujoco.MjData(model)
mujoco.mj_forward(model, data)
"""

#: Headless rendering (EGL, its context left to the display's teardown at exit) and a Rerun
#: recording (its background threads alive at exit), as the suite's tests do.
RENDER_AND_RECORD = SCENE + """
import tempfile
from pathlib import Path

import numpy as np
import rerun as rr

from cell.robots.camera import CameraRig

with CameraRig(model, "eye", 64, 48) as rig:
    image = rig.rgb(data)
stream = rr.RecordingStream("musclecell-exit-check")
stream.save(Path(tempfile.mkdtemp()) / "exit.rrd")
stream.log("image", rr.Image(image))
stream.flush()
stream.disconnect()
"""

#: Two LLVMs in one process (numba's JIT and Mesa's llvmpipe behind EGL), torch's OpenMP
#: threads, and a renderer alive at exit with its context still current: MuJoCo's own atexit
#: hook terminates the EGL display first, then the renderer's finaliser frees its GL objects.
RENDERER_LEFT_CURRENT = SCENE + """
import numba
import numpy as np
import torch

from OpenGL import EGL


@numba.njit(cache=False)
def total(values):
    return values.sum()


total(np.arange(10.0))
torch.ones(64, 64) @ torch.ones(64, 64)
renderer = mujoco.Renderer(model, 48, 64)
renderer.update_scene(data, "eye")
renderer.render()
assert EGL.eglGetCurrentContext()
"""

#: Two OpenMP runtimes in one process, each with its threads alive at exit: coacd's own
#: libgomp, loaded first by a CAD part's decomposition, then torch's (the suite does both in one
#: session; a library's copy of a runtime is torn down beside the other's).
TWO_OPENMPS = """
import coacd
import trimesh

mesh = trimesh.creation.icosphere(subdivisions=2)
coacd.set_log_level("error")
coacd.run_coacd(coacd.Mesh(mesh.vertices, mesh.faces), threshold=0.05, seed=1)

import torch

torch.ones(256, 256) @ torch.ones(256, 256)
"""

#: An episode's recorder over the coarse cell, one frame logged, in a folder of its own.
RECORDER = """
import sys
import tempfile
from pathlib import Path

import mujoco
import numpy as np

from cell.errors import OutputError
from cell.sim.assembly import build_scene
from cell.sim.recording import EpisodeRecorder
from cell.sim.scenario import Scenario
from cell.tissue.geometry import MuscleShape

scene = build_scene(Scenario(tissue=MuscleShape(cell_size_m=0.05)))
data = mujoco.MjData(scene.model)
mujoco.mj_forward(scene.model, data)
folder = Path(sys.argv[1])
recorder = EpisodeRecorder(folder / "episode.rrd", scene, "exit-check")


def log_frame() -> None:
    data.time += 0.01
    recorder.log_frame(data, knife_tip_m=np.zeros(3), scalars={"progress/released": 0.0})


log_frame()
"""

#: A thread still logging frames when the main thread exits (Rerun's threads then free
#: NumPy-backed buffers while the interpreter finalises, unless the recording was aborted
#: first): the crash at exit reproduced.
THREAD_LOGGING_AT_EXIT = RECORDER + """
import threading
import time


def keep_logging() -> None:
    try:
        while True:
            log_frame()
            recorder.log_look(1, np.zeros((50, 3)), np.random.rand(2000, 3), np.zeros((50, 3)))
    except OutputError:  # aborted at exit: the thread ends
        return


threading.Thread(target=keep_logging, daemon=True).start()
time.sleep(0.3)
"""

#: Rendering and recording, then a local Ray started and stopped (its gRPC threads outlive
#: ray.shutdown).
WITH_RAY = RENDER_AND_RECORD + """
from cell.scale.pool import RunPool, Workers


def negate(value: int) -> int:  # Ray takes Python functions, not builtins
    return -value


with RunPool(Workers(1, ray=True)) as pool:
    assert sorted(pool.play(negate, [2], ["n"])) == [(0, -2, "")]
"""


def _exits_cleanly(code: str, *args: str) -> None:
    environment = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONFAULTHANDLER": "1",
                   "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
                   "RAY_USAGE_STATS_ENABLED": "0"}
    done = subprocess.run([sys.executable, "-X", "faulthandler", "-c", textwrap.dedent(code),
                           *args],
                          cwd=ROOT, env=environment, stdin=subprocess.DEVNULL,
                          capture_output=True, text=True, check=False)
    assert done.returncode == 0 and "Fatal Python error" not in done.stderr, (
        f"exit status {done.returncode}:\n{done.stderr[-4000:]}")


def test_rendering_and_recording_exit_cleanly() -> None:
    _exits_cleanly(RENDER_AND_RECORD)


def test_a_renderer_left_current_beside_two_llvms_exits_cleanly() -> None:
    pytest.importorskip("torch")
    if os.environ.get("MUJOCO_GL", "egl") != "egl":
        pytest.skip("the EGL display's teardown at exit is the case checked")
    _exits_cleanly(RENDERER_LEFT_CURRENT)


def test_two_openmp_runtimes_exit_cleanly() -> None:
    pytest.importorskip("torch")
    pytest.importorskip("coacd")
    _exits_cleanly(TWO_OPENMPS)


def test_a_recording_left_open_at_exit_is_aborted_and_leaves_no_file(tmp_path: Path) -> None:
    _exits_cleanly(RECORDER, str(tmp_path))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("run", [0, *(pytest.param(k, marks=pytest.mark.slow)
                                      for k in range(1, 40))])
def test_a_thread_logging_at_exit_is_stopped_and_the_process_exits_cleanly(
        run: int, tmp_path: Path) -> None:
    _exits_cleanly(THREAD_LOGGING_AT_EXIT, str(tmp_path))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
@pytest.mark.parametrize("run", range(20))
def test_rendering_recording_and_ray_exit_cleanly_again_and_again(run: int) -> None:
    _exits_cleanly(WITH_RAY)
