"""Each force sample of a log batch is weighed by how well a replay predicts it
(cell.logs.chaos): the spread of the lab's nudged replays there, beside the sensor's noise
averaged over the compared window; a stretch where the replays scatter (a tear that comes or
not) no longer drowns the stretches that tell the cause."""

from __future__ import annotations

import zlib

import numpy as np
import pytest

import cell.logs.diagnosis as logdiagnosis
from cell.logs.chaos import chaos_scales, samples_averaged
from cell.logs.diagnosis import diagnose_logs
from cell.logs.fit import COMPARED_WINDOW_S, logged_vector
from cell.logs.outcome import EVIDENCE_ROWS, control_step_s
from tests.logs.test_heldout import BATCH, PARAMS, TRUE_MAGNITUDE, LinearWorld

MEASURED, ROWS = logged_vector(list(BATCH.logs), EVIDENCE_ROWS)
#: The second half of the middle log's force samples.
CHAOTIC = ROWS.force & (ROWS.log == 1) & (np.cumsum(ROWS.log == 1) > (ROWS.log == 1).sum() / 2)


def _replays(spread_at: np.ndarray, size: float) -> list[np.ndarray]:
    rng = np.random.default_rng(1)
    return [MEASURED + size * rng.normal(size=MEASURED.size) * spread_at for _ in range(5)]


def test_samples_where_the_lab_s_replays_scatter_weigh_less() -> None:
    scales = chaos_scales(BATCH.logs, ROWS, _replays(CHAOTIC, 1.0), noise_n=0.01)
    steady = ROWS.force & (ROWS.log != 1)
    assert scales[CHAOTIC].max() < 0.2 * scales[steady].min()
    assert np.mean(scales[ROWS.force] ** 2) == pytest.approx(1.0)
    assert np.all(scales[~ROWS.force] == 1.0)


def test_where_the_replays_agree_a_log_weighs_by_the_samples_its_window_averages() -> None:
    scales = chaos_scales(BATCH.logs, ROWS, _replays(CHAOTIC, 0.0), noise_n=0.01)
    first, last = (scales[ROWS.force & (ROWS.log == i)] for i in (0, 2))
    averaged = [samples_averaged(COMPARED_WINDOW_S, control_step_s(BATCH.logs[i]))
                for i in (0, 2)]
    assert np.ptp(first) == pytest.approx(0.0) and np.ptp(last) == pytest.approx(0.0)
    assert (first[0] / last[0]) ** 2 == pytest.approx(averaged[0] / averaged[1])


class ChaoticWorld(LinearWorld):
    """A linear world whose every replay scatters on the second half of the middle log by a
    term (drawn from the world) many times the cause's effect."""

    def run(self, jobs: list[tuple[int, dict[str, float]]]) -> list[np.ndarray]:
        out = super().run(jobs)
        for vector, (log, world) in zip(out, jobs, strict=True):
            seed = zlib.crc32(repr((log, sorted(world.items()))).encode())
            chaotic = CHAOTIC[ROWS.log == log]
            vector += (4.0 * np.random.default_rng(seed).normal(size=vector.size) * chaotic
                       * (1.0 if self.scales is None else self.scales[log]))
        return out


def test_a_cause_is_named_at_its_magnitude_beside_a_stretch_of_chaos(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(logdiagnosis, "Replayer", ChaoticWorld)
    result = diagnose_logs(BATCH, PARAMS).to_json()
    assert result["causes"] == ["tearing_threshold"]
    fitted = result["extended"]["params"]["tearing_threshold"]["magnitude"]
    assert fitted == pytest.approx(TRUE_MAGNITUDE, rel=0.05)
