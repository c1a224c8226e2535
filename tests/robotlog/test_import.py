"""``musclecell import``: robot logs of cuts in every form ROS records become one cut-test set,
the same set whatever the form; a bad mapping or log is a named error and writes nothing."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cell.cli import main
from cell.errors import FrameError, MappingError, MissingTopicError, NoContactError
from cell.measure.specimens import load_measurement_set
from cell.robotlog.cutlog import import_cut_set
from cell.robotlog.mapping import mapping_from_toml
from tests.robotlogs import (
    MAPPING_TOML,
    sawing_cut,
    write_dumps,
    write_mcap,
    write_ros1_bag,
    write_ros2_bag,
)

pytest.importorskip("rosbags")

try:
    import tomllib
except ImportError:  # pragma: no cover
    import tomli as tomllib


def _mapping(**changes: dict) -> object:
    raw = tomllib.loads(MAPPING_TOML)
    for table, keys in changes.items():
        raw[table].update(keys)
    return mapping_from_toml(raw)


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The same two cuts in every form: per form, the two logs."""
    root = tmp_path_factory.mktemp("logs")
    forms = {"dumps": lambda log, p: write_dumps(log, p),
             "ros1": lambda log, p: write_ros1_bag(log, p.with_suffix(".bag")),
             "ros2": lambda log, p: write_ros2_bag(log, p),
             "ros2-mcap": lambda log, p: write_ros2_bag(log, p, "mcap"),
             "mcap": lambda log, p: write_mcap(log, p.with_suffix(".mcap"))}
    found = {}
    for form, write in forms.items():
        (root / form).mkdir()
        found[form] = [write(sawing_cut(seed), root / form / f"cut{seed}") for seed in (0, 1)]
    return found


def test_every_form_of_the_same_logs_gives_the_same_set(logs, tmp_path):
    texts = {}
    for form, sources in logs.items():
        out = import_cut_set(_mapping(), sources, tmp_path / form)
        texts[form] = (out / "tests.csv").read_text()
    assert len(set(texts.values())) == 1, {form: len(text) for form, text in texts.items()}
    data = load_measurement_set(tmp_path / "dumps")
    assert [test.test_id for test in data.cut_tests] == ["cut0", "cut1"]


def test_the_block_frame_puts_the_first_contact_at_the_top_faces_middle(logs, tmp_path):
    data = load_measurement_set(import_cut_set(_mapping(), logs["dumps"], tmp_path / "set"))
    test = data.cut_tests[0]
    log = sawing_cut(0)
    # the wrench's samples while the position is logged, the times the test keeps
    kept = (log.wrench_ns >= log.position_ns[0]) & (log.wrench_ns <= log.position_ns[-1])
    force = log.force_n[kept]
    assert test.time_s * 1e9 == pytest.approx(log.wrench_ns[kept] - log.wrench_ns[kept][0],
                                              abs=1e3)
    contact = int(np.argmax(np.linalg.norm(force - force[0], axis=1) > 1.0))
    assert test.edge_m[contact] == pytest.approx([0.02, 0.1, 0.05], abs=1e-8)
    # the force keeps its axes (normal, edge, up are the base's x, y, z) to the writer's 0.1 mN
    assert test.force_n == pytest.approx(force, abs=6e-5)
    assert test.time_s[0] == 0.0
    depth = test.depth_m(data.block)
    assert depth[0] < 0.0 < depth[-1]


def test_a_board_height_or_a_top_height_places_the_same_top_face(logs, tmp_path):
    by_board = import_cut_set(_mapping(cut={"contact_force_n": None, "board_height_m": 0.18}),
                              logs["dumps"][:1], tmp_path / "board")
    by_top = import_cut_set(_mapping(cut={"contact_force_n": None, "top_height_m": 0.23}),
                            logs["dumps"][:1], tmp_path / "top")
    assert (by_board / "tests.csv").read_text() == (by_top / "tests.csv").read_text()
    (test,) = load_measurement_set(by_top).cut_tests
    assert test.edge_m[0, 2] == pytest.approx(0.05 + 0.005, abs=1e-4)


def test_a_topic_the_log_lacks_is_named_with_those_it_has(logs, tmp_path):
    mapping = _mapping(wrench={"topic": "/ft/raw"})
    for form in ("dumps", "ros1", "mcap"):
        with pytest.raises(MissingTopicError, match=r"ft_wrench|/ft/wrench"):
            import_cut_set(mapping, logs[form], tmp_path / form)
        assert not (tmp_path / form).exists()


def test_a_frame_other_than_the_mappings_is_refused(logs, tmp_path):
    with pytest.raises(FrameError, match="tool0"):
        import_cut_set(_mapping(wrench={"frame": "tool0"}, position={"frame": "tool0"},
                                cut={"frame": "tool0"}), logs["ros2"], tmp_path / "set")
    assert not (tmp_path / "set").exists()


def test_a_wrench_in_a_sensors_frame_needs_the_rotation_into_the_cuts(tmp_path):
    log = sawing_cut(0)
    # sensor x = base y, sensor y = -base x
    turned = replace(log, force_n=log.force_n[:, [1, 0, 2]] * [1, -1, 1], frame="sensor")
    write_dumps(turned, tmp_path / "cut0")
    with pytest.raises(FrameError, match="give the rotation"):
        import_cut_set(_mapping(wrench={"frame": "sensor"}), [tmp_path / "cut0"],
                       tmp_path / "set")
    # the rotation from sensor to base, row by row
    mapping = _mapping(wrench={"frame": "sensor", "rotation": [0, -1, 0, 1, 0, 0, 0, 0, 1]})
    (test,) = load_measurement_set(import_cut_set(mapping, [tmp_path / "cut0"],
                                                  tmp_path / "set")).cut_tests
    kept = (log.wrench_ns >= log.position_ns[0]) & (log.wrench_ns <= log.position_ns[-1])
    assert test.force_n == pytest.approx(log.force_n[kept], abs=6e-5)


def test_a_log_where_the_blade_never_meets_the_block_is_named(logs, tmp_path):
    with pytest.raises(NoContactError, match="never rises 500"):
        import_cut_set(_mapping(cut={"contact_force_n": 500.0}), logs["dumps"], tmp_path / "s")
    with pytest.raises(NoContactError, match="never reaches"):
        import_cut_set(_mapping(cut={"contact_force_n": None, "top_height_m": 0.1}),
                       logs["dumps"], tmp_path / "s")


@pytest.mark.parametrize(("table", "keys", "field"), [
    ("cut", {"blade_normal": [0.0, 1.0, 0.0]}, "cut.blade_normal"),
    ("cut", {"top_height_m": 0.2}, "cut.top_height_m"),
    ("wrench", {"sign": 2.0}, "wrench.sign"),
    ("wrench", {"rotation": [1.0, 0.0]}, "wrench.rotation"),
    ("blade", {"edge_lenght_m": 0.2}, "blade.edge_lenght_m"),
])
def test_a_bad_mapping_is_named_by_its_key(table, keys, field):
    with pytest.raises(MappingError) as caught:
        _mapping(**{table: keys})
    assert caught.value.field == field


def test_the_command_writes_the_set_or_nothing(logs, tmp_path, capsys):
    mapping = tmp_path / "mapping.toml"
    mapping.write_text(MAPPING_TOML)
    assert main(["import", str(mapping), *map(str, logs["mcap"]), "--out",
                 str(tmp_path / "set")]) == 0
    assert len(load_measurement_set(tmp_path / "set").cut_tests) == 2
    mapping.write_text(MAPPING_TOML.replace("[blade]", "[blades]"))
    assert main(["import", str(mapping), *map(str, logs["mcap"]), "--out",
                 str(tmp_path / "other")]) == 2
    assert "mapping.toml, blades: unknown table" in capsys.readouterr().err
    assert not (tmp_path / "other").exists()


def test_a_round_section_in_the_mapping_reaches_the_set(logs, tmp_path):
    out = import_cut_set(_mapping(block={"section": "round"}), logs["dumps"], tmp_path / "set")
    assert load_measurement_set(out).block.section == "round"
