"""The old module names of the redrawn library import for one release, as the new modules,
with a warning that says where each went (:mod:`cell.moved`)."""

from __future__ import annotations

import importlib
import sys

import pytest

from cell.moved import MOVED


def _fresh_import(name: str) -> object:
    sys.modules.pop(name, None)
    return importlib.import_module(name)


@pytest.mark.parametrize("old", sorted(MOVED))
def test_an_old_name_imports_with_a_warning_naming_where_it_went(old: str) -> None:
    new = MOVED[old]
    with pytest.warns(DeprecationWarning, match=f"{old} moved to .*next release"):
        module = _fresh_import(old)
    if isinstance(new, str):
        assert module is importlib.import_module(new)


def test_an_old_module_split_in_two_lends_the_names_of_both() -> None:
    from cell.diagnosis.engine import search, selection
    with pytest.warns(DeprecationWarning, match="engine.search and .*engine.selection"):
        old = _fresh_import("cell.rheology.search")
    assert old.Search is search.Search  # not copies: the same objects
    assert (old.forward, old.second_start, old.Swap, old.unexplained) == (
        selection.forward, selection.second_start, selection.Swap, selection.unexplained)
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        _ = old.no_such_name
