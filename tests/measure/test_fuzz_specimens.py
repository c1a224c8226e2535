"""Fuzzing measurement sets (``specimen.toml`` and ``tests.csv``) and force curves: random
specimens, columns, modes, ids and numbers (NaN, infinities, 1e308, text), blank and comment
lines. Reading must return or raise a named error; a set that reads is then simulated on the
default meat, which must give finite forces or a named error (:mod:`tests.fuzzing`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import strategies as st

from cell.diagnosis.specimen.solve import simulate_set
from cell.errors import MusclecellError
from cell.measure.specimens import MODES, load_measurement_set
from cell.tissue.forcecurve import ForceCurve
from cell.tissue.material import default_meat
from tests.fuzzing import (
    cells,
    fuzz_tests,
    mostly,
    numbers,
    scratch,
    tables,
    toml_document,
    written,
)
from tests.refusals import refused

COLUMNS = ("test_id", "mode", "angle_deg", "time_s", "displacement_m", "force_N")


@st.composite
def measurement_sets(draw: st.DrawFn) -> tuple[str, str]:
    """A set's two files: a specimen (mostly well formed, its numbers fuzzed) and tests."""
    size = draw(mostly(st.lists(st.floats(0.001, 0.05), min_size=3, max_size=3),
                       st.lists(numbers(), max_size=4)))
    specimen: dict[str, Any] = {"name": "fuzz", "size_m": size}
    if draw(st.booleans()):
        specimen["density_kg_m3"] = draw(mostly(st.floats(500.0, 2000.0), numbers()))
    if draw(mostly(st.just(False), st.just(True), 20)):
        specimen.pop(draw(st.sampled_from(["name", "size_m"])))
    mode, angle = draw(st.sampled_from(MODES)), draw(st.sampled_from(["0", "45", "90"]))
    tests = draw(tables(COLUMNS, {
        "test_id": mostly(st.just("a"), st.sampled_from(["", "b"]), 50),
        "mode": mostly(st.just(mode), st.sampled_from([*MODES, "twist"]), 50),
        "angle_deg": mostly(st.just(angle), cells(), 50),
        "displacement_m": mostly(st.floats(-0.003, 0.003).map(repr), cells(), 30),
        "force_N": mostly(st.floats(-5.0, 5.0).map(repr), cells(), 30)}, "time_s"))
    return toml_document({"specimen": specimen}), tests


def _check_set(files: tuple[str, str]) -> None:
    with scratch() as folder:
        root = written(Path(folder) / "set", {"specimen.toml": files[0], "tests.csv": files[1]})
        try:
            data = load_measurement_set(root)
            runs = simulate_set(data, default_meat())
        except MusclecellError:
            return
        for run in runs:
            assert np.all(np.isfinite(run.force_n)), run.test_id


test_measurement_sets, test_measurement_sets_slow = fuzz_tests(
    measurement_sets(), _check_set, 250)


def _check_curve(text: str) -> None:
    with scratch() as folder:
        path = written(Path(folder), {"curve.csv": text}) / "curve.csv"
        try:
            curve = ForceCurve.from_csv(path)
        except MusclecellError:
            return
        assert np.all(np.isfinite(curve.force_n)) and np.all(np.diff(curve.time_s) > 0)


test_force_curves, test_force_curves_slow = fuzz_tests(
    tables(("time_s", "force_n"), {"force_n": mostly(st.floats(0.0, 50.0).map(repr), cells())},
           "time_s"), _check_curve, 150)


def _check_cli_set(files: tuple[str, str]) -> None:
    """A fuzzed set made sure to be bad (a last row whose values land, whatever the column
    order, as an absurd number or text in a number's column): ``diagnose`` exits 2 naming a
    file of the set, no traceback, the working folder as it was."""
    with scratch() as folder:
        cwd = Path(folder)
        written(cwd, {"set/specimen.toml": files[0], "out/kept.txt": "before\n",
                      "set/tests.csv": files[1] + "\na,tension,0,0,0,1e308\n"})
        message = refused(cwd, "diagnose", "set", "--out", "out/d.json", words=("set/",))
        assert "specimen.toml" in message or "tests.csv" in message, message


test_cli_sets, test_cli_sets_slow = fuzz_tests(measurement_sets(), _check_cli_set, 3,
                                               slow_examples=40)
