"""The live view (``musclecell run --view``): served to a browser where there is no display,
started, serving and stopped cleanly; a window asked for without a display is a named error,
in the command and in the envs (``human`` rendering); the envs' views take their size."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

from cell.errors import InputError
from envs.separation import MuscleSeparationEnv
from tests.refusals import refused

SHORT = ('[scenario]\nname = "short"\nend_s = 0.3\n[tissue]\ncell_size_m = 0.05\nlength_m = '
         "0.3\n[perception]\nenabled = false\n")


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _headless() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    return {**env, "MUJOCO_GL": "egl"}


def _listening(port: int) -> bool:
    with socket.socket() as probe:
        return probe.connect_ex(("127.0.0.1", port)) == 0


@pytest.mark.slow  # an episode in a viewer
def test_view_without_a_display_serves_the_web_viewer_and_stops(tmp_path: Path) -> None:
    (tmp_path / "short.toml").write_text(SHORT)
    grpc, web = _free_port(), _free_port()
    command = [sys.executable, "-m", "cell.cli", "run", "short.toml", "--view", "--grpc-port",
               str(grpc), "--web-port", str(web), "--view-hold", "3", "--quiet"]
    run = subprocess.Popen(command, cwd=tmp_path, env=_headless(), stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
    try:
        page = None
        deadline = time.monotonic() + 120
        while page is None and run.poll() is None and time.monotonic() < deadline:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{web}/", timeout=2) as answer:
                    page = answer.status, answer.read()
            except OSError:
                time.sleep(0.2)
        served_grpc = _listening(grpc)
        out, err = run.communicate(timeout=120)
    finally:
        run.kill()
    assert run.returncode == 0, err
    assert page is not None and page[0] == 200 and b"<html" in page[1].lower()
    assert served_grpc
    assert f"http://localhost:{web}/?url=rerun%2Bhttp%3A%2F%2Flocalhost%3A{grpc}" in err
    assert "released" in out
    assert not _listening(grpc) and not _listening(web)  # stopped with the command
    assert sorted(p.name for p in tmp_path.iterdir()) == ["short.toml"]  # no file left


def test_spawning_the_viewer_without_a_display_is_refused(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "short.toml").write_text(SHORT)
    for name in ("DISPLAY", "WAYLAND_DISPLAY"):
        monkeypatch.delenv(name, raising=False)
    if sys.platform in ("darwin", "win32"):
        pytest.skip("a display is always there")  # pragma: no cover
    refused(tmp_path, "run", "short.toml", "--view", "spawn",
            words=("--view", "needs a display", "--view serve"))


def test_human_rendering_without_a_display_is_a_named_error(monkeypatch: pytest.MonkeyPatch
                                                            ) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    if sys.platform in ("darwin", "win32"):
        pytest.skip("a display is always there")  # pragma: no cover
    with pytest.raises(InputError, match=r"render_mode: human .* needs a display"):
        MuscleSeparationEnv(render_mode="human")


def test_the_envs_render_at_the_size_asked() -> None:
    env = MuscleSeparationEnv(driven="knife", render_mode="rgb_array", width=200, height=100,
                              cell_size_m=0.05)
    try:
        env.reset(seed=0)
        assert env.render().shape == (100, 400, 3)  # the camera's view beside the overview
    finally:
        env.close()
    with pytest.raises(InputError, match=r"width: must be an integer in 16\.\.4096 px"):
        MuscleSeparationEnv(render_mode="rgb_array", width=8)
