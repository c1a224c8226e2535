"""The default count of worker processes: one per usable core, or MUSCLECELL_WORKERS."""

from __future__ import annotations

import pytest

from cell.cores import WORKERS_VARIABLE, default_workers, usable_cores
from cell.diagnosis.engine.settings import DiagnosisParams
from cell.errors import InputError


def test_the_variable_sets_the_default_of_a_diagnosis(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(WORKERS_VARIABLE, "3")
    assert DiagnosisParams().workers == 3
    assert DiagnosisParams(workers=2).workers == 2


def test_without_the_variable_every_usable_core_works(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(WORKERS_VARIABLE, raising=False)
    assert default_workers() == usable_cores() >= 1


@pytest.mark.parametrize("text", ["0", "-2", "two", "1.5"])
def test_a_value_that_is_no_count_is_named(monkeypatch: pytest.MonkeyPatch, text: str) -> None:
    monkeypatch.setenv(WORKERS_VARIABLE, text)
    with pytest.raises(InputError, match=f"{WORKERS_VARIABLE}: must be a whole number"):
        default_workers()


def test_work_whose_steps_wait_on_several_tasks_runs_one_worker_each(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(WORKERS_VARIABLE, raising=False)
    assert default_workers(usable_cores() + 2) == usable_cores() + 2
    assert default_workers(1) == usable_cores()
    monkeypatch.setenv(WORKERS_VARIABLE, "1")
    assert default_workers(3) == 1
