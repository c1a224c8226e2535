"""Log batches from worlds changed the way a user changes one (cell.bench.keyworlds): the keys
each cause maps to edited in the scenario and material files and read back, the sizes drawn,
the logs written of the world the lab believes, and the bench kinds that use them."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np
import pytest

from cell.bench.diagnose_logs import (
    FIRST_SEED,
    TUNING_SEEDS,
    bench_seeds,
    hidden,
    log_pairs,
    log_table,
)
from cell.bench.keyworlds import (
    FACTOR_RANGE,
    LARGE_FACTOR,
    cause_edits,
    draw_size,
    world_files,
    write_key_change_batch,
)
from cell.cli import main
from cell.config import read_toml
from cell.errors import LogError
from cell.logs.causes import CAUSES, changed_world
from cell.sim.scenario import load_scenario
from cell.sim.scenariotoml import resolved_tables
from tests.paths import PROJECT_ROOT

QUICK = PROJECT_ROOT / "scenarios" / "quick.toml"


@pytest.mark.parametrize("cause", list(CAUSES))
def test_editing_a_causes_keys_makes_the_world_the_cause_makes(cause: str) -> None:
    base = load_scenario(QUICK)
    size = math.radians(35.0) if CAUSES[cause].kind == "angle" else 0.45
    magnitude = size if CAUSES[cause].kind == "angle" else math.log(size)
    with tempfile.TemporaryDirectory() as folder:
        edited = load_scenario(world_files(Path(folder), base, resolved_tables(
            read_toml(QUICK), base), cause_edits(base, {cause: size})))
    expected = changed_world(base, {cause: magnitude})
    assert edited.aponeurosis == expected.aponeurosis
    assert edited.material == expected.material
    assert edited.material != base.material or edited.aponeurosis != base.aponeurosis


def test_two_causes_editing_one_key_make_the_world_both_causes_make() -> None:
    base = load_scenario(QUICK)
    sizes = {"binding_strength": 2.31, "binding_stiffness": 0.68}
    with tempfile.TemporaryDirectory() as folder:
        edited = load_scenario(world_files(Path(folder), base, resolved_tables(
            read_toml(QUICK), base), cause_edits(base, sizes)))
    expected = changed_world(base, {c: math.log(size) for c, size in sizes.items()})
    assert edited.aponeurosis.stiffness_n_m == pytest.approx(
        expected.aponeurosis.stiffness_n_m, rel=1e-12)
    assert edited.aponeurosis.stiffness_n_m == pytest.approx(
        base.aponeurosis.stiffness_n_m * 2.31 * 0.68, rel=1e-12)
    assert edited.aponeurosis.toughness_j_m2 == pytest.approx(
        expected.aponeurosis.toughness_j_m2, rel=1e-12)


def test_one_key_alone_is_edited_and_a_key_that_is_no_number_is_named() -> None:
    base = load_scenario(QUICK)
    tables = resolved_tables(read_toml(QUICK), base)
    with tempfile.TemporaryDirectory() as folder:
        edited = load_scenario(world_files(Path(folder), base, tables,
                                           {"aponeurosis.stiffness_n_m": 2.5}))
        assert edited.aponeurosis.stiffness_n_m == pytest.approx(
            2.5 * base.aponeurosis.stiffness_n_m)
        assert edited.aponeurosis.toughness_j_m2 == base.aponeurosis.toughness_j_m2
        with pytest.raises(LogError, match=r"aponeurosis\.law"):
            world_files(Path(folder), base, tables, {"aponeurosis.law": 2.0})


def test_the_sizes_are_large_half_the_time_either_way_and_never_near_one() -> None:
    rng = np.random.default_rng(5)
    factors = np.array([draw_size("tearing_threshold", rng) for _ in range(400)])
    assert factors.min() >= 1 / FACTOR_RANGE[1] and factors.max() <= FACTOR_RANGE[1]
    assert not np.any((factors > 1 / FACTOR_RANGE[0]) & (factors < FACTOR_RANGE[0]))
    large = (factors >= LARGE_FACTOR) | (factors <= 1 / LARGE_FACTOR)
    assert 0.4 < large.mean() < 0.6 and 0.4 < (factors < 1.0).mean() < 0.6
    angles = [abs(math.degrees(draw_size("fibre_direction", rng))) for _ in range(50)]
    low, high = CAUSES["fibre_direction"].typical
    assert low <= min(angles) and max(angles) <= high


def test_a_batch_logs_the_believed_world_on_drawn_shapes(tmp_path: Path) -> None:
    truth = write_key_change_batch(tmp_path / "batch", seed=3, base=QUICK,
                                   causes=("tearing_threshold",), logs=1, end_s=0.04)
    assert truth.causes == ("tearing_threshold",) and truth.offset_channel == ""
    factor = truth.magnitudes["tearing_threshold"]
    assert 1 / FACTOR_RANGE[1] <= factor <= FACTOR_RANGE[1]
    belief = load_scenario(tmp_path / "batch" / "log-1" / "scenario.toml")
    base = load_scenario(QUICK)
    assert belief.aponeurosis == base.aponeurosis and belief.material == base.material
    assert belief.tissue != base.tissue and truth.shapes[0]
    assert all(getattr(belief.tissue, key) == value for key, value in truth.shapes[0].items())
    assert (tmp_path / "batch" / "log-1" / "log.toml").is_file()


def test_the_key_kinds_cycle_through_the_world_causes_on_seeds_of_their_own() -> None:
    table = log_table("keys")
    assert "sensor_offset" not in table and set(table) == set(log_table()) - {"sensor_offset"}
    assert [hidden(s, "keys") for s in bench_seeds(len(table) + 3, "keys")] == [
        (c,) for c in table] + [()] * 3
    pairs = log_pairs("key-pairs")
    assert {hidden(FIRST_SEED["key-pairs"] + k, "key-pairs") for k in range(len(pairs))} == set(
        pairs)
    seeds = set(bench_seeds(100, "keys")) | set(bench_seeds(100, "key-pairs"))
    assert not seeds & (set(TUNING_SEEDS) | set(bench_seeds(100)) | set(bench_seeds(100, "pairs")))


def test_scenario_keys_go_with_the_log_batches_only(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "diagnose", "--scenario-keys", "--out", "x.json"]) == 2
    assert "--scenario-keys" in capsys.readouterr().err


def test_a_first_seed_starts_the_log_batches_elsewhere_and_goes_with_them_only(
        capsys: pytest.CaptureFixture[str]) -> None:
    fresh = bench_seeds(18, "keys", first=72_100)
    assert fresh == list(range(72_100, 72_118))
    assert sorted(hidden(s, "keys") for s in fresh) == sorted(
        hidden(s, "keys") for s in bench_seeds(18, "keys"))
    assert main(["bench", "diagnose", "--first-seed", "72100", "--out", "x.json"]) == 2
    assert "--first-seed" in capsys.readouterr().err
    assert main(["bench", "diagnose", "--logs", "--first-seed", "5", "--out", "x.json"]) == 2
    assert "the tests'" in capsys.readouterr().err
