"""The safe reader of :mod:`cell.io` and the strict writers of :mod:`cell.outputs`, case by
case: every fault of a file is a named error with its path, JSON is written without NaN, and
no temporary file outlives a write that was stopped.
"""

from __future__ import annotations

import json
import os
import pickle
from pathlib import Path

import pytest

from cell import io as cell_io
from cell.config import FORCE_N, LENGTH_M, MODULUS_PA, from_table, read_toml, updated
from cell.errors import (
    FileTooLargeError,
    InputError,
    MissingFileError,
    NotAFileError,
    NotFiniteResultError,
    NotTextError,
    SweepError,
    UnreadableFileError,
    file_read_error,
)
from cell.io import read_json, read_text
from cell.measure.specimens import Specimen
from cell.outputs import AtomicFile, write_atomic, write_json, write_together
from cell.sim.scenario import SimulationParams


def test_a_named_pipe_is_refused_without_waiting_for_a_writer(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "pipe.toml")
    with pytest.raises(NotAFileError, match="not a regular file"):
        read_text(tmp_path / "pipe.toml", "toml")


def test_a_file_too_large_for_its_kind(tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                                       ) -> None:
    monkeypatch.setitem(cell_io.MAX_INPUT_BYTES, "csv", 64)
    (tmp_path / "big.csv").write_text("a\n" * 100)
    with pytest.raises(FileTooLargeError, match="larger than any csv input") as error:
        read_text(tmp_path / "big.csv", "csv")
    assert error.value.file == str(tmp_path / "big.csv")


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads any file")
def test_an_unreadable_file(tmp_path: Path) -> None:
    path = tmp_path / "secret.toml"
    path.write_text("a = 1\n")
    path.chmod(0)
    with pytest.raises(UnreadableFileError, match="permission denied"):
        read_toml(path)


def test_nul_bytes_are_not_text(tmp_path: Path) -> None:
    (tmp_path / "z.csv").write_bytes(b"time_s,force_n\n0,\x001\n")
    with pytest.raises(NotTextError, match="NUL"):
        read_text(tmp_path / "z.csv", "csv")


def test_a_missing_file_and_a_missing_folder(tmp_path: Path) -> None:
    for path in (tmp_path / "gone.toml", tmp_path / "gone" / "x.toml"):
        with pytest.raises(MissingFileError, match="file not found"):
            read_text(path, "toml")


def test_a_read_error_is_also_the_readers_own_and_survives_pickling() -> None:
    error = file_read_error(NotTextError, SweepError)("s.toml", None, "not UTF-8 text")
    again = pickle.loads(pickle.dumps(error))
    assert isinstance(again, SweepError) and isinstance(again, NotTextError)
    assert str(again) == "s.toml: not UTF-8 text"


def test_json_is_read_strictly(tmp_path: Path) -> None:
    (tmp_path / "r.json").write_text('{"gain": NaN}')
    with pytest.raises(InputError, match="NaN is not a JSON number"):
        read_json(tmp_path / "r.json")
    (tmp_path / "bad.json").write_text('{"gain": 1,,}')
    with pytest.raises(InputError, match="not valid JSON") as error:
        read_json(tmp_path / "bad.json")
    assert error.value.field == "line 1"


def test_json_is_written_strictly_and_names_the_non_finite_key(tmp_path: Path) -> None:
    target = tmp_path / "out" / "d.json"
    with pytest.raises(NotFiniteResultError) as error:
        write_json(target, {"fit": {"rmse_n": [0.1, float("inf")]}, "ok": 1})
    assert error.value.key == "fit.rmse_n[1]" and "nothing written" in str(error.value)
    assert not target.parent.exists() or not any(target.parent.iterdir())
    write_json(target, {"gain": None, "rmse_n": 0.5})
    assert json.loads(target.read_text()) == {"gain": None, "rmse_n": 0.5}


@pytest.mark.parametrize("stop", [KeyboardInterrupt, SystemExit, OSError])
def test_a_stopped_write_leaves_no_temporary(tmp_path: Path, stop: type[BaseException]
                                             ) -> None:
    (tmp_path / "kept.txt").write_text("before")
    with pytest.raises(stop), AtomicFile(tmp_path / "kept.txt") as target:
        target.temporary.write_text("half")
        raise stop()
    assert [p.name for p in tmp_path.iterdir()] == ["kept.txt"]
    assert (tmp_path / "kept.txt").read_text() == "before"


def test_write_atomic_leaves_no_temporary_when_the_content_fails(tmp_path: Path) -> None:
    with pytest.raises(TypeError):
        write_atomic(tmp_path / "x.txt", 3)  # type: ignore[arg-type]
    assert list(tmp_path.iterdir()) == []


def test_files_written_together_change_none_when_one_cannot_be_written(tmp_path: Path) -> None:
    (tmp_path / "report.json").write_text("before")
    (tmp_path / "blocked").write_text("a file where a folder should be")
    with pytest.raises(OSError):
        write_together({tmp_path / "report.json": "after", tmp_path / "report.md": "after",
                        tmp_path / "blocked" / "episodes.csv": "after"})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocked", "report.json"]
    assert (tmp_path / "report.json").read_text() == "before"
    written = write_together({tmp_path / "report.json": "after", tmp_path / "t.npz": b"\x00"})
    assert [path.read_bytes() for path in written] == [b"after", b"\x00"]


def test_plausible_ranges_let_real_values_through_and_refuse_absurd_ones() -> None:
    for plausible, real, absurd in ((FORCE_N, 250.0, 1e308), (LENGTH_M, 0.45, 1e6),
                                    (MODULUS_PA, 3e4, 1e-5)):
        assert plausible.refusal(real) is None
        assert "not plausible" in str(plausible.refusal(absurd))


def test_a_missing_required_key_is_named() -> None:
    with pytest.raises(InputError, match="missing key") as error:
        from_table(Specimen, {"name": "x"}, file="s.toml", section="specimen")
    assert error.value.field == "specimen.size_m"


def test_a_change_refused_by_another_fields_check_names_the_change() -> None:
    with pytest.raises(InputError) as error:
        updated(SimulationParams(), {"timestep_s": 0.05}, section="simulation")
    assert error.value.field == "simulation.timestep_s"
    assert "control_rate_hz" in error.value.message


def test_a_material_of_no_plausible_stiffness_is_not_written() -> None:
    from cell.errors import MaterialError
    from cell.tissue.material import MassSpringMaterial
    from cell.tissue.materialfile import material_to_toml

    with pytest.raises(MaterialError, match="not plausible") as error:
        material_to_toml(MassSpringMaterial.isotropic(1e-5))
    assert error.value.field == "longitudinal"


def test_a_steep_exponential_modulus_is_refused_naming_the_exponent(tmp_path: Path) -> None:
    from cell.errors import MaterialError
    from cell.tissue.materialfile import load_material

    (tmp_path / "m.toml").write_text('model = "mass_spring"\n[longitudinal]\nmodulus_pa = 1e4\n'
                                     "exponent = 1000.0\n[transverse]\nmodulus_pa = 1e4\n")
    with pytest.raises(MaterialError, match="not plausible") as error:
        load_material(tmp_path / "m.toml")
    assert error.value.field == "longitudinal.exponent"
