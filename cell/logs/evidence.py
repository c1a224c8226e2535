"""The evidence of the log diagnosis, in the engine's shape
(:class:`cell.diagnosis.engine.outcome.Evidence`): per named cause, the held-out force RMSE of
the logs with the extended world (replayed) and without the cause (linearised), and the share
of the logs it improves.

Example:
    >>> LogEvidence("tissue_stiffness", 0.4, 2.0, 1.0, {}, None).to_json()["linearised"]
    True
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from cell.diagnosis.engine.outcome import Evidence
from cell.logs.fit import Rows, heldout, rmse_n
from cell.logs.search import OFFSET, fixed


@dataclass(frozen=True)
class LogEvidence(Evidence):
    """:class:`~cell.diagnosis.engine.outcome.Evidence` for a cause of the logs: its
    ``improved_fraction`` is the share of the logs (each held out) whose error it lowers, its
    ``params`` empty (the magnitudes are the extended world's ``params``; the log diagnosis
    gives no intervals), ``without`` None.

    Attributes:
        channel: the channel of a ``sensor_offset`` ("" for a world cause).
        linearised: the error without the cause is linearised (from the signatures), the one
            with it replayed.

    Example:
        >>> LogEvidence("sensor_offset", 0.4, 2.0, 1.0, {}, None, channel="knife"
        ...             ).to_json()["channel"]
        'knife'
    """

    channel: str = ""
    linearised: bool = True

    def to_json(self) -> dict[str, Any]:
        """The engine's ``evidence`` entry, with the channel (an offset's) and
        ``linearised``."""
        return {**super().to_json(), **({"channel": self.channel} if self.channel else {}),
                "linearised": self.linearised}


def log_evidence(residual: np.ndarray, blocks: dict[str, np.ndarray], rows: Rows,
                 chosen: list[str], left: np.ndarray) -> list[LogEvidence]:
    """Per named block (a world cause, or a sensor's offset on a channel), the held-out RMSE
    of the logs with the extended world (``left``, replayed) and without the block
    (linearised), and the share of the logs it improves."""
    out = []
    for name in chosen:
        others = {c: blocks[c] for c in chosen if c != name}
        without = heldout(residual, others, rows, fixed(others))
        logs = np.unique(rows.log)
        better = [rmse_n(left[rows.log == i]) < rmse_n(without[rows.log == i]) for i in logs]
        cause, _, channel = name.partition(":") if name.startswith(OFFSET) else (name, "", "")
        out.append(LogEvidence(cause, rmse_n(left), rmse_n(without), float(np.mean(better)),
                               {}, None, channel=channel))
    return out
