"""The modules that moved when the library was redrawn into rooms by concern, importable
under their old names for one release, with a :class:`DeprecationWarning` (the CHANGELOG
lists them).

An old name is the new module itself (``cell.rheology.measured`` is
``cell.measure.specimens``), so its state and classes are shared, never copied. An old module
whose names went to two new ones (``cell.rheology.search``: the search to
``cell.diagnosis.engine.search``, the selection to ``cell.diagnosis.engine.selection``) is a
module that looks each name up in them, in order.

Example:
    >>> import warnings
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore", DeprecationWarning)
    ...     from cell.rheology.measured import load_measurement_set
    >>> load_measurement_set.__module__
    'cell.measure.specimens'
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import types
import warnings

#: Old module name -> new module name, or the new modules its names went to.
MOVED: dict[str, str | tuple[str, ...]] = {
    "cell.rheology.acceptance": "cell.diagnosis.engine.acceptance",
    "cell.rheology.search": ("cell.diagnosis.engine.search",
                             "cell.diagnosis.engine.selection"),
    "cell.rheology.settings": "cell.diagnosis.engine.settings",
    "cell.determined": "cell.diagnosis.engine.determined",
    "cell.rheology.causeplots": "cell.diagnosis.specimen.plots",
    "cell.rheology.causes": ("cell.diagnosis.specimen.causes",
                             "cell.diagnosis.specimen.causes.candidate"),
    "cell.rheology.diagnosis": "cell.diagnosis.specimen.diagnosis",
    "cell.rheology.fitting": "cell.diagnosis.specimen.fitting",
    "cell.rheology.intervals": "cell.diagnosis.specimen.intervals",
    "cell.rheology.repeats": "cell.diagnosis.specimen.repeats",
    "cell.rheology.repeatsearch": "cell.diagnosis.specimen.repeatsearch",
    "cell.rheology.report": "cell.diagnosis.specimen.report",
    "cell.rheology.specimen": "cell.diagnosis.specimen.solve",
    "cell.rheology.spread": "cell.diagnosis.specimen.spread",
    "cell.rheology.suggest": "cell.diagnosis.specimen.suggest",
    "cell.rheology.suggesttests": "cell.diagnosis.specimen.nexttests",
    "cell.rheology.command": "cell.diagnosis.command",
    "cell.rheology.cutdiagnosis": "cell.diagnosis.sets",
    "cell.rheology.cutcauses": "cell.diagnosis.cut.causes",
    "cell.rheology.cutfitting": "cell.diagnosis.cut.fitting",
    "cell.rheology.cutreduced": "cell.diagnosis.cut.reduced",
    "cell.rheology.cutreport": "cell.diagnosis.cut.report",
    "cell.rheology.cutsearch": "cell.diagnosis.cut.search",
    "cell.rheology.residuals": "cell.diagnosis.cut.residuals",
    "cell.rheology.measured": "cell.measure.specimens",
    "cell.rheology.cuts": "cell.measure.cuts",
    "cell.rheology.testplan": "cell.measure.protocols",
    "cell.rheology.testrows": "cell.measure.testrows",
    "cell.sim.logformat": "cell.measure.logs",
    "cell.rheology.synthetic": "cell.synthetic.specimen",
    "cell.rheology.truth": "cell.synthetic.truth",
    "cell.sim.cutsets": "cell.synthetic.cut",
    "cell.sim.logsets": "cell.synthetic.logs",
    "cell.sim.cutscore": "cell.sim.score",
    "cell.sim.logwriter": "cell.sim.episodelog",
    "cell.sim.cuttest": "cell.cuttest.run",
    "cell.sim.cuttestscene": "cell.cuttest.scene",
    "cell.sim.logbatch": "cell.logs.batch",
    "cell.sim.logcauses": "cell.logs.causes",
    "cell.sim.logcommand": "cell.logs.command",
    "cell.sim.logdiagnosis": "cell.logs.diagnosis",
    "cell.sim.logfit": "cell.logs.fit",
    "cell.sim.logreplays": "cell.logs.replays",
    "cell.sim.logreport": "cell.logs.report",
    "cell.sim.logsearch": ("cell.logs.search", "cell.logs.causes"),
    "cell.sim.replay": "cell.logs.replay",
}
#: Old packages that hold nothing of their own any more.
_EMPTIED = ("cell.rheology",)


class _Alias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds an old name and loads it as its new module."""

    def __init__(self) -> None:
        self._own_specs: dict[str, importlib.machinery.ModuleSpec] = {}

    def find_spec(self, name: str, path: object = None,
                  target: object = None) -> importlib.machinery.ModuleSpec | None:
        if name not in MOVED and name not in _EMPTIED:
            return None
        return importlib.machinery.ModuleSpec(name, self, is_package=name in _EMPTIED)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType:
        if spec.name in _EMPTIED:
            return types.ModuleType(spec.name, "Moved: see cell.moved.")
        new = MOVED[spec.name]
        warnings.warn(f"{spec.name} moved to {' and '.join(_names(new))}; the old name goes "
                      "in the next release", DeprecationWarning, stacklevel=2)
        if isinstance(new, tuple):
            return _lookup_module(spec.name, [importlib.import_module(name) for name in new])
        module = importlib.import_module(new)
        self._own_specs[spec.name] = module.__spec__
        return module

    def exec_module(self, module: types.ModuleType) -> None:
        # The import system gave the new module the old name's spec: give its own back.
        own = self._own_specs.pop(module.__spec__.name, None)
        if own is not None:
            module.__spec__ = own


def _names(new: str | tuple[str, ...]) -> tuple[str, ...]:
    return new if isinstance(new, tuple) else (new,)


def _lookup_module(name: str, modules: list[types.ModuleType]) -> types.ModuleType:
    """A module named ``name`` whose attributes are those of ``modules``, first found first."""
    sources = ", ".join(source.__name__ for source in modules)
    module = types.ModuleType(name, f"Moved: its names are in {sources}.")

    def lookup(attribute: str) -> object:
        for source in modules:
            if hasattr(source, attribute):
                return getattr(source, attribute)
        raise AttributeError(f"module {name!r} has no attribute {attribute!r}")

    module.__getattr__ = lookup  # type: ignore[method-assign]  # PEP 562
    return module


def install() -> None:
    """Let the old names be imported (once; :mod:`cell` calls it)."""
    if not any(isinstance(finder, _Alias) for finder in sys.meta_path):
        sys.meta_path.append(_Alias())
