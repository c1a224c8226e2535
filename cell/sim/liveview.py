"""A live view of an episode: Rerun's viewer fed as the episode runs (``musclecell run
--view``), beside or instead of the ``.rrd`` file.

Two ways to look: ``spawn`` starts the native viewer (a window: needs a display) and streams
to it; ``serve`` serves the recording over gRPC and the web viewer over HTTP, for a browser on
this machine or, through a forwarded port, another one (a headless server). ``auto`` spawns
where there is a display and serves where there is none.
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass
from urllib.parse import quote

import rerun as rr

from cell.errors import InputError, Stopped

#: The ways ``--view`` opens the viewer.
VIEW_MODES = ("auto", "spawn", "serve")


def has_display() -> bool:
    """Whether a window can open here: always on macOS and Windows, with ``DISPLAY`` or
    ``WAYLAND_DISPLAY`` set elsewhere."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


@dataclass(frozen=True)
class LiveView:
    """How the episode's recording is shown while it runs.

    Attributes:
        mode: ``spawn`` (the native viewer, in a window), ``serve`` (gRPC and the web viewer,
            for a browser) or ``auto`` (``spawn`` where there is a display, else ``serve``).
        grpc_port: the port the recording is streamed on (spawn: the viewer's; serve: ours).
        web_port: the port the web viewer is served on (serve only).
        hold_s: how long the served view stays up after the episode, s (None: until Ctrl-C,
            which then ends the command as done).

    Example:
        >>> LiveView("serve").web_url()
        'http://localhost:9090/?url=rerun%2Bhttp%3A%2F%2Flocalhost%3A9876%2Fproxy'
    """

    mode: str = "auto"
    grpc_port: int = 9876
    web_port: int = 9090
    hold_s: float | None = None

    def __post_init__(self) -> None:
        if self.mode not in VIEW_MODES:
            raise InputError(None, "--view", f"must be one of {', '.join(VIEW_MODES)}, got "
                             f"{self.mode!r}")
        for name in ("grpc_port", "web_port"):
            port = getattr(self, name)
            if not 0 < port < 65536:
                raise InputError(None, f"--{name.replace('_', '-')}",
                                 f"must be a port, 1-65535, got {port}")
        if self.mode == "spawn" and not has_display():
            raise InputError(None, "--view", "spawn opens the viewer in a window, which needs "
                             "a display (DISPLAY or WAYLAND_DISPLAY); there is none here: use "
                             "--view serve and a browser")
        if self.hold_s is not None and not self.hold_s >= 0:
            raise InputError(None, "--view-hold", f"must be >= 0 s, got {self.hold_s}")

    def resolved(self) -> str:
        """``spawn`` or ``serve``: what ``auto`` means here."""
        if self.mode != "auto":
            return self.mode
        return "spawn" if has_display() else "serve"

    def grpc_url(self) -> str:
        """The gRPC address a viewer reads the recording from."""
        return f"rerun+http://localhost:{self.grpc_port}/proxy"

    def web_url(self) -> str:
        """The address a browser opens to see the served recording."""
        return f"http://localhost:{self.web_port}/?url={quote(self.grpc_url(), safe='')}"

    def sinks(self) -> list[rr.GrpcSink | rr.GrpcServerSink]:
        """The recording's sinks for this view; starts the viewer (spawn) or the web viewer
        (serve), and says where to look on stderr."""
        if self.resolved() == "spawn":
            rr.spawn(port=self.grpc_port, connect=False)
            return [rr.GrpcSink(self.grpc_url())]
        server = rr.GrpcServerSink(port=self.grpc_port)
        rr.serve_web_viewer(web_port=self.web_port, open_browser=False)
        print(f"musclecell: live view at {self.web_url()} (the recording's gRPC server: "
              f"{self.grpc_url()})", file=sys.stderr, flush=True)
        return [server]

    def hold(self) -> None:
        """After the episode, keep a served view up for :attr:`hold_s` (or until Ctrl-C); a
        spawned viewer has the recording already and stays open by itself."""
        if self.resolved() != "serve":
            return
        if self.hold_s is not None:
            time.sleep(self.hold_s)
            return
        print("musclecell: the episode is over; serving the live view until Ctrl-C",
              file=sys.stderr, flush=True)
        try:
            while True:
                time.sleep(1.0)
        except KeyboardInterrupt as stop:
            if isinstance(stop, Stopped):  # SIGTERM, SIGHUP: a stop, not the viewer's end
                raise
