"""The diagnosis report: two figures that decode and a Markdown summary naming what was found."""

from __future__ import annotations

from pathlib import Path

import pytest

from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.specimen.diagnosis import diagnose
from cell.diagnosis.specimen.report import write_report
from cell.measure.specimens import load_measurement_set
from cell.synthetic.specimen import write_hidden_effect_set


@pytest.mark.slow  # a whole diagnosis
def test_report_shows_the_figures_the_cause_and_the_gain(tmp_path: Path) -> None:
    image = pytest.importorskip("matplotlib.image")
    write_hidden_effect_set(tmp_path / "set", 3, "force_offset")
    result = diagnose(load_measurement_set(tmp_path / "set"), DiagnosisParams())
    assert result.causes == ("force_offset",)
    paths = write_report(result, tmp_path / "report", tmp_path / "material.toml")
    assert [p.name for p in paths] == ["forces.png", "residuals.png", "cause-force_offset.png",
                                       "report.md"]
    for png in paths[:2]:
        assert png.read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
        height, width, _ = image.imread(png).shape
        assert height > 500 and width > 1000
    markdown = paths[-1].read_text()
    assert "force_offset" in markdown and f"Gain {result.gain:.3f}" in markdown
    assert "(../material.toml)" in markdown and "(forces.png)" in markdown
    assert "## Evidence" in markdown and "(cause-force_offset.png)" in markdown
    assert image.imread(paths[2]).shape[1] > 500
    assert not list((tmp_path / "report").glob(".*.tmp"))
