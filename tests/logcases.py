"""Separation logs made in memory for the log diagnosis's tests: smooth force waves on every
channel, no episode behind them."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cell.measure.logs import Channel, SeparationLog


def wave_log(n: int, offset: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> SeparationLog:
    """A log of ``n`` samples over 1 s: waves on the knife and the gripper, the knife's on the
    fixture plus ``offset`` (N)."""
    t = np.linspace(0.0, 1.0, n)
    wave = np.stack([np.sin(3 * t), np.cos(2 * t), t], axis=1)
    pose = {"position_m": np.zeros((n, 3)), "quaternion": np.tile([1.0, 0, 0, 0], (n, 1))}
    channels = {"knife": Channel(t, wave, **pose), "gripper": Channel(t, 2 * wave, **pose),
                "fixture": Channel(t, wave + np.asarray(offset))}
    return SeparationLog(Path("log"), "log", Path("scenario.toml"), 0, channels)
