"""Starting or joining Ray, for every command that plays on it (sweeps, batches, log replays,
training): the address forms of ``--address``, a reachability check that fails fast, and an
error that says how to install Ray.

Ray is the ``scale`` extra: it is imported only when a command plays on it.

Example:
    >>> check_address("ray://head:10001", "--address")
    >>> check_address("head", "--address")
    Traceback (most recent call last):
    cell.errors.PoolError: --address: not a Ray address: 'head' (auto, HEAD_HOST:PORT or ray://HOST:PORT)
"""

from __future__ import annotations

import logging
import os
import re
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from cell.cores import usable_cores
from cell.errors import PoolError

#: A cluster's address: its head's ``HOST:PORT`` or its client server's ``ray://HOST:PORT``.
_ADDRESS = re.compile(r"(?:ray://)?(?P<host>[A-Za-z0-9._\-]+|\[[0-9A-Fa-f:]+\])"
                      r":(?P<port>\d{1,5})")
#: How long a cluster's head may take to answer before the address counts as unreachable, s.
CONNECT_TIMEOUT_S = 5.0
#: What the CLI tells a user without Ray: how to install it, then what runs without it.
INSTALL_HINT = "pip install -e '.[scale]'"
#: What a sweep or a batch runs without Ray.
WITHOUT_RAY = "--workers 1 runs without Ray, in this process"


def check_address(address: str, option: str) -> None:
    """Raise :class:`PoolError` on ``option`` unless ``address`` is ``auto``, ``HOST:PORT``
    or ``ray://HOST:PORT``."""
    if address == "auto":
        return
    match = _ADDRESS.fullmatch(address)
    if match is None or not 0 < int(match["port"]) < 65536:
        raise PoolError(None, option, f"not a Ray address: {address!r} "
                        "(auto, HEAD_HOST:PORT or ray://HOST:PORT)")


@contextmanager
def ray_session(address: str | None, option: str, instead: str = WITHOUT_RAY,
                cpus: int | None = None) -> Iterator[Any]:
    """The ``ray`` module, joined to the cluster at ``address`` (None: a Ray of its own on
    this machine, ``cpus`` workers, default one per core) unless this process already is;
    left again on exit if this call joined.

    Raises:
        PoolError: on ``option``: not a Ray address, no Ray (saying how to install it, or
            ``instead``), an address that does not answer, or Ray failing to start or join.
    """
    if address is not None:
        check_address(address, option)
    ray = require_ray(option, instead)
    joined = not ray.is_initialized()
    if joined:
        _reachable(address)
        try:
            ray.init(**_init_options(address, cpus))
        except (ConnectionError, TimeoutError, RuntimeError, ValueError) as exc:
            raise PoolError(None, option, f"cannot start or join Ray: {exc}") from None
    try:
        yield ray
    finally:
        if joined:
            ray.shutdown()


def _init_options(address: str | None, cpus: int | None) -> dict[str, Any]:
    # Workers render the camera headless, as `musclecell run` does.
    options: dict[str, Any] = {
        "runtime_env": {"env_vars": {"MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}},
        "log_to_driver": False, "logging_level": logging.WARNING}
    if address is not None:
        return {**options, "address": address}
    # "local": a Ray of its own, even where `ray start` left one running on this machine.
    return {**options, "address": "local", "num_cpus": cpus or usable_cores(),
            "include_dashboard": False}


def _reachable(address: str | None) -> None:
    """Fail within :data:`CONNECT_TIMEOUT_S` where a ``HOST:PORT`` address does not answer:
    Ray itself keeps trying for a minute or more.

    Raises:
        PoolError: naming ``--address`` and what the connection said.
    """
    match = None if address is None else _ADDRESS.fullmatch(address)
    if match is None:
        return
    host = match["host"].strip("[]")
    try:
        socket.create_connection((host, int(match["port"])), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        raise PoolError(None, "--address", f"cannot reach {address}: "
                        f"{exc.strerror or exc or 'no answer'}") from None


def require_ray(option: str, instead: str = WITHOUT_RAY) -> Any:
    """The ``ray`` module, or a :class:`~cell.errors.PoolError` on ``option`` that says how to
    install it, or ``instead`` what runs without it.

    Usage statistics are off unless the user turned them on: musclecell does not report to
    anyone, and CI machines have no network.
    """
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    try:
        import ray
    except ImportError:
        raise PoolError(None, option,
                        f"Ray is not installed: {INSTALL_HINT} (or {instead})") from None
    return ray
