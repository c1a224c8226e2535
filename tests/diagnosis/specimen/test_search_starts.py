"""The starts of the search's fits (``cell/diagnosis/specimen/search.py``): a load-cell offset added
to a model is also fitted with the model's compression terms back at their tension values, where
an offset missing from the fit before had bent them."""

from types import SimpleNamespace

import numpy as np

from cell.diagnosis.specimen.causes import CandidateMaterial
from cell.diagnosis.specimen.search import _mirrored


def test_the_compression_terms_restart_at_their_tension_twins() -> None:
    model = CandidateMaterial(("strain_stiffening", "anisotropy", "force_offset"), oblique=True)
    names = model.parameter_names
    shape = np.arange(len(names), dtype=float)
    mirrored_names, values = _mirrored(SimpleNamespace(model=model, shape=shape))
    assert mirrored_names == names
    value = dict(zip(names, values, strict=True))
    assert value["log_el_over_et_compressed"] == value["log_el_over_et"]
    assert value["oblique_compressed"] == value["oblique"]
    assert value["compression_stiffening_exponent"] == value["stiffening_exponent"]
    assert value["log_el_over_et"] == shape[names.index("log_el_over_et")]
    assert shape[names.index("oblique_compressed")] == names.index("oblique_compressed")
