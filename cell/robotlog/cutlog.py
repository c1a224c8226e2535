"""A robot's log of a cut turned into a cut test (:class:`cell.measure.cuts.CutTest`), and a
set of them into a measurement set (docs/robot-logs.md).

The wrench and the position are recorded apart, each at its own uneven rate: the test keeps
the wrench's samples and reads the position at their times (linear between its own samples,
which move smoothly where a force does not). The block frame is the mapping's (blade normal,
edge, up); its origin is placed so that the edge meets the top face at the middle of the
block's footprint, at the sample where the top face is found.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from cell.errors import FrameError, NoContactError, RobotLogError
from cell.folders import write_folder
from cell.measure.cuts import Blade, Block, CutTest, cut_rows_csv
from cell.measure.specimens import SPECIMEN_FILE, TESTS_FILE, load_measurement_set
from cell.robotlog.mapping import ImportMapping
from cell.robotlog.topics import TopicSeries, read_topic

#: Where a wrench message keeps its force: ``WrenchStamped``, then ``Wrench``.
FORCE_FIELDS = ("wrench.force", "force")
#: Where a position message keeps its point, in the order they are looked for.
POSITION_FIELDS = ("vector", "point", "pose.position", "pose.pose.position",
                   "transform.translation", "position")


def cut_test_from_log(source: str | Path, mapping: ImportMapping, test_id: str) -> CutTest:
    """The cut test that the log at ``source`` records, as ``mapping`` reads it.

    Raises:
        MissingTopicError: a topic the mapping names is not in the log.
        FrameError: a topic in another frame than the mapping gives it.
        NoContactError: the blade never meets the block.
        RobotLogError: times that do not overlap, a message without the fields needed.
    """
    source = Path(source)
    wrench = read_topic(source, mapping.wrench.topic)
    position = read_topic(source, mapping.position.topic)
    _check_frame(wrench, mapping.wrench.frame or mapping.cut.frame)
    _check_frame(position, mapping.position.frame or mapping.cut.frame)
    if _differ(mapping.position.frame, mapping.cut.frame):
        raise FrameError(mapping.path, "position.frame", f"{mapping.position.frame!r} is not "
                         f"the cut's frame {mapping.cut.frame!r}: log the position in it")
    force = mapping.wrench.sign * wrench.vector(FORCE_FIELDS)
    if mapping.wrench.rotation:
        force = force @ np.reshape(mapping.wrench.rotation, (3, 3)).T
    elif _differ(mapping.wrench.frame, mapping.cut.frame):
        raise FrameError(mapping.path, "wrench.rotation", f"the wrench is in "
                         f"{mapping.wrench.frame!r}, the cut in {mapping.cut.frame!r}: give the "
                         "rotation between them")
    point = position.vector(POSITION_FIELDS) + np.asarray(mapping.position.edge_offset_m)
    time_ns, force = _increasing(wrench.time_ns, force)
    point_ns, point = _increasing(position.time_ns, point)
    inside = (time_ns >= point_ns[0]) & (time_ns <= point_ns[-1])
    if inside.sum() < 3:
        raise RobotLogError(source, mapping.position.topic, "its times and the wrench's "
                            "overlap in fewer than 3 samples")
    time_ns, force = time_ns[inside], force[inside]
    start = time_ns[0]
    time_s = (time_ns - start) * 1e-9
    edge = np.column_stack([np.interp(time_s, (point_ns - start) * 1e-9, point[:, axis])
                            for axis in range(3)])
    axes = mapping.cut.axes
    edge, force = edge @ axes.T, force @ axes.T
    return CutTest(test_id, time_s, edge - _origin(source, edge, force, mapping), force)


def _differ(frame: str, cut_frame: str) -> bool:
    """Whether two frames the mapping names are not one (an unnamed one is any)."""
    return bool(frame and cut_frame and frame != cut_frame)


def _check_frame(series: TopicSeries, frame: str) -> None:
    named = sorted(series.frame_ids - {""})
    if frame and named and named != [frame]:
        raise FrameError(series.source, series.topic, f"its messages are in frame "
                         f"{', '.join(named)}, the mapping gives {frame!r}")


def _increasing(time_ns: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The samples whose time is later than every one before (a log's repeats dropped)."""
    keep = time_ns > np.maximum.accumulate(np.concatenate([[time_ns[0] - 1], time_ns[:-1]]))
    return time_ns[keep], values[keep]


def _origin(source: Path, edge: np.ndarray, force: np.ndarray, mapping: ImportMapping
            ) -> np.ndarray:
    """The block frame's origin in the cut's axes: the edge meets the top face at the middle
    of the footprint, at the sample where the top face is found (:class:`CutFrame`)."""
    cut, size = mapping.cut, np.asarray(mapping.block.size_m)
    if cut.contact_force_n is not None:
        touching = np.linalg.norm(force - force[0], axis=1) > cut.contact_force_n
        if not touching.any():
            raise NoContactError(source, mapping.wrench.topic, f"the force never rises "
                                 f"{cut.contact_force_n} N above its first sample")
        first = int(np.argmax(touching))
        top = edge[first, 2]
    else:
        top = (cut.top_height_m if cut.top_height_m is not None
               else cut.board_height_m + size[2])
        below = edge[:, 2] <= top
        if not below.any():
            raise NoContactError(source, mapping.position.topic, f"the edge never reaches the "
                                 f"top face at {top} m")
        first = int(np.argmax(below))
    return np.array([edge[first, 0] - size[0] / 2, edge[first, 1] - size[1] / 2,
                     top - size[2]])


def import_cut_set(mapping: ImportMapping, sources: Sequence[str | Path], out: str | Path
                   ) -> Path:
    """Write the measurement set of one cut test per log of ``sources`` (named after each
    log's file or folder) into the folder ``out``, whole or not at all, and check it reads
    back as any set does; returns the folder.

    Raises:
        RobotLogError: two logs of one name, or any error of :func:`cut_test_from_log`.
        InputError: the set the logs make is refused by the set's reader (an edge that starts
            inside the block, ...).
    """
    names = [Path(source).stem if Path(source).is_file() else Path(source).name
             for source in sources]
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise RobotLogError(None, "sources", f"two logs named {twice[0]!r}: each becomes a "
                            "test named after its file or folder")
    tests = [cut_test_from_log(source, mapping, name)
             for source, name in zip(sources, names, strict=True)]
    block = Block(mapping.block.size_m, mapping.block.fibre_direction,
                  section=mapping.block.section)
    blade = Blade(mapping.blade.edge_length_m, mapping.blade.thickness_m, (0.0, 1.0, 0.0),
                  (1.0, 0.0, 0.0), mapping.blade.edge_angle_deg,
                  *(() if mapping.blade.edge_radius_m is None else (mapping.blade.edge_radius_m,)))

    def fill(folder: Path) -> None:
        (folder / SPECIMEN_FILE).write_text(_specimen_toml(block, blade, names, mapping))
        (folder / TESTS_FILE).write_text(cut_rows_csv(tests))
        load_measurement_set(folder)

    return write_folder(out, fill)


def _specimen_toml(block: Block, blade: Blade, names: Sequence[str], mapping: ImportMapping
                   ) -> str:
    def vector(values: Sequence[float]) -> str:
        return f"[{', '.join(repr(float(v)) for v in values)}]"

    lines = [f"# Imported by musclecell import from {len(names)} robot logs "
             f"({', '.join(names)})" + (f" with the mapping {mapping.path.name}"
                                       if mapping.path else "") + ".",
             "", "[block]", f"size_m = {vector(block.size_m)}"]
    if block.fibre_direction is not None:
        lines.append(f"fibre_direction = {vector(block.fibre_direction)}")
    if block.section != "box":
        lines.append(f'section = "{block.section}"')
    lines += ["", "[blade]", f"edge_length_m = {blade.edge_length_m!r}",
              f"thickness_m = {blade.thickness_m!r}",
              f"edge_direction = {vector(blade.edge_direction)}",
              f"blade_normal = {vector(blade.blade_normal)}"]
    if blade.edge_angle_deg is not None:
        lines.append(f"edge_angle_deg = {blade.edge_angle_deg!r}")
    lines.append(f"edge_radius_m = {blade.edge_radius_m!r}")
    return "\n".join(lines) + "\n"
