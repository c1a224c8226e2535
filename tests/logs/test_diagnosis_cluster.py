"""The batch diagnosis of separation logs on a Ray cluster (`diagnose-logs --address`, `bench
diagnose --logs --address`), without starting Ray: the options refused before any work, the
batch shipped to the cluster as data (not as folders its nodes may not have), a replay lost on
the cluster named. tests/logs/test_diagnosis_ray.py diagnoses a batch on a real cluster."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cell.cli import main
from cell.errors import PoolError
from cell.logs.batch import read_log_batch
from cell.logs.replays import Replayer
from cell.progress import progress_bar
from cell.scale.pool import RunPool, Workers
from cell.synthetic.logs import write_hidden_log_batch
from tests.paths import PROJECT_ROOT

QUICK = PROJECT_ROOT / "scenarios" / "quick.toml"


@pytest.fixture(scope="module")
def tiny_batch(tmp_path_factory: pytest.TempPathFactory) -> list[str]:
    """Two logs of 0.1 s on the quick scenario (no hidden cause): their folders."""
    folder = tmp_path_factory.mktemp("tiny") / "batch"
    write_hidden_log_batch(folder, 5, QUICK, (), logs=2, end_s=0.1)
    return [str(folder / "log-1"), str(folder / "log-2")]


@pytest.mark.parametrize("argv, named", [
    (["diagnose-logs", "a", "b", "--address", "nonsense"], ["--address", "not a Ray address"]),
    (["diagnose-logs", "a", "b", "--address", "host:99999"], ["--address", "not a Ray address"]),
    (["diagnose-logs", "a", "b", "--address", "auto", "--workers", "0"], ["--workers", ">= 1"]),
    (["bench", "diagnose", "--logs", "--address", "nonsense"], ["--address", "nonsense"]),
    (["bench", "diagnose", "--address", "auto"], ["--address", "bench diagnose --logs"]),
    (["bench", "env", "--address", "auto"], ["--address", "bench diagnose --logs"]),
])
def test_a_bad_address_is_refused_before_any_work(tmp_path: Path, argv: list[str],
                                                 named: list[str],
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    assert main([*argv, "--out", str(out)]) == 2
    message = capsys.readouterr().err
    assert all(part in message for part in named), message
    assert not out.exists()


def test_without_ray_the_address_says_how_to_install_it(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch,
                                                        capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # what `import ray` meets when not installed
    out = tmp_path / "out"
    assert main(["diagnose-logs", "a", "b", "--out", str(out), "--address", "auto"]) == 2
    message = capsys.readouterr().err
    assert "--address" in message and "pip install -e '.[scale]'" in message
    assert "drop --address" in message
    assert main(["bench", "diagnose", "--logs", "--address", "auto", "--out",
                 str(out)]) == 2
    assert "pip install -e '.[scale]'" in capsys.readouterr().err
    assert not out.exists()


class _Recording:
    """A pool that plays in this process and keeps what it was sent; ``lost`` names the
    positions whose worker dies."""

    def __init__(self, lost: Sequence[int] = ()) -> None:
        self.shared: list[Any] = []
        self.tasks: list[Any] = []
        self.lost = lost

    def share(self, value: Any) -> Any:
        self.shared.append(value)
        return value

    def play(self, function: Callable[..., Any], tasks: Sequence[Any], names: Sequence[str],
             shared: Any = None) -> Iterator[tuple[int, Any, str]]:
        self.tasks += list(tasks)
        for position, task in enumerate(tasks):
            if position in self.lost:
                yield position, None, "WorkerCrashedError: the worker died"
            else:
                yield position, function(shared, task), ""


def test_the_cluster_gets_the_batch_once_as_data_and_tasks_name_a_log_and_a_world(
        tiny_batch: list[str]) -> None:
    batch = read_log_batch(tiny_batch)
    pool = _Recording()
    with Replayer(batch, 1, pool) as replayer:
        (world,) = replayer.batches([{"tissue_stiffness": 0.2}])
        replayer.run([(1, {})])
    assert pool.shared == [batch]  # sent once, as data
    assert pool.tasks == [(0, (("tissue_stiffness", 0.2),)), (1, (("tissue_stiffness", 0.2),)),
                          (1, ())]  # no folder in a task
    assert world is not None and replayer.count == 3
    assert replayer.cpu_s > 0.0 and not replayer.in_process


def test_a_replay_lost_on_the_cluster_is_named(tiny_batch: list[str]) -> None:
    with (Replayer(read_log_batch(tiny_batch), 1, _Recording(lost=[1])) as replayer,
          pytest.raises(PoolError, match=r"--address: replay-1-\S+ gave no result: "
                        "WorkerCrashedError")):
        replayer.run([(0, {}), (1, {})])


def test_a_replay_of_the_shipped_batch_is_the_replay_of_its_folder(tiny_batch: list[str]
                                                                   ) -> None:
    batch = read_log_batch(tiny_batch)
    with RunPool(Workers(1)) as pool, Replayer(batch, 1, pool) as replayer:
        (vector,) = replayer.run([(0, {})])
    with Replayer(batch, 1) as here:
        assert np.array_equal(vector, here.run([(0, {})])[0])


@pytest.mark.parametrize("quiet", [False, True])
def test_the_replays_show_done_of_planned_and_their_round_unless_quiet(
        tiny_batch: list[str], quiet: bool, capsys: pytest.CaptureFixture[str]) -> None:
    with (Replayer(read_log_batch(tiny_batch), 1) as replayer,
          progress_bar("replay", quiet=quiet, total=0) as bar):
        replayer.progress = bar
        replayer.round = "held out"
        replayer.run([(0, {}), (1, {})])
    shown = capsys.readouterr().err
    assert (shown == "") == quiet
    if not quiet:
        assert "held out" in shown and "2/2" in shown
