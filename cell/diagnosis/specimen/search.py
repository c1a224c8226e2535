"""The specimen family on the engine's search (:class:`SpecimenSearch`): the uniaxial
catalogue, the two kinds of viscoelasticity that exclude each other, the model variants of an
added cause, the extra starts of the causes that others absorb, and the tests a non-linear
relaxation is judged on.

Usage::

    search = SpecimenSearch(problem, params, root, pool)
    baseline = search.run([(None, None)])[0]
    final, steps, order = forward(search, baseline, search.run(
        [(baseline, c) for c in search.catalogue]), noise)
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from cell.diagnosis.engine.acceptance import Rules, Tests
from cell.diagnosis.engine.fit import Fit, Start
from cell.diagnosis.engine.search import Search
from cell.diagnosis.specimen.causes import EXCLUSIVE, CandidateMaterial, catalogue
from cell.diagnosis.specimen.fitting import ModelFit, fit
from cell.diagnosis.specimen.planeseries import PlaneSeries
from cell.measure.shearbiaxial import SHEAR_MODE

#: The load cell's offset: judged on the samples at rest.
OFFSET = "force_offset"
#: The fibres' turn: judged on the shear tests (:func:`_judged`).
TURN = "fibre_direction"
# Causes that the other causes' parameters absorb in part while they are missing: added to a
# model, they are also fitted from the model's own start.
_ABSORBED = (*EXCLUSIVE, OFFSET)


def _judged(richer: Fit, poorer: Fit, tests: Tests) -> list[int]:
    """The tests on which ``richer`` is judged against ``poorer``: those that show what it adds
    to first order, where they are fewer than the set's. The ramp-and-hold ones when all it
    adds is to make poorer's relaxation non-linear (a relaxed fraction that depends on the
    strain shows in holds alone; on the other tests its slope only trades misfit with the
    other causes); the shear tests when all it adds is the fibres' turn (a turn shears the
    fibre-sheet plane's stiffness into the shear modes, while a stretch along or across the
    plane sees it only through the square of its cosine); every test otherwise (and when the
    set has none of those)."""
    causes, other = set(richer.model.causes), set(poorer.model.causes)
    if EXCLUSIVE[1] in causes and EXCLUSIVE[0] in other and causes - {EXCLUSIVE[1]} <= other:
        shown = [i for i, test in enumerate(tests) if test.mode == "relaxation"]
    elif causes - other == {TURN}:
        shown = [i for i, test in enumerate(tests) if test.mode.startswith(SHEAR_MODE)]
    else:
        shown = []
    return shown or list(range(len(tests)))


def _mirrored(fitted: ModelFit) -> tuple[tuple[str, ...], np.ndarray]:
    """``fitted``'s (names, values) with each compression term (``*_compressed``,
    ``compression_*``) at the value of its tension twin."""
    names, values = fitted.model.parameter_names, fitted.shape.copy()
    for i, name in enumerate(names):
        twin = name.removesuffix("_compressed").removeprefix("compression_")
        if twin != name and twin in names:
            values[i] = values[names.index(twin)]
    return names, values


class SpecimenSearch(Search):
    """The engine's :class:`~cell.diagnosis.engine.search.Search` over the uniaxial causes,
    fitting candidate materials (:func:`cell.diagnosis.specimen.fitting.fit`); ``root`` is
    the material every candidate extends.

    Example:
        >>> SpecimenSearch.rules.offsets
        ('force_offset',)
    """

    exclusive = EXCLUSIVE
    rules = Rules(offsets=(OFFSET,), judged=_judged)
    fit_model = staticmethod(fit)

    @property
    def catalogue(self) -> tuple[str, ...]:  # type: ignore[override]
        """The registered causes (:func:`cell.diagnosis.specimen.causes.registry.catalogue`)
        that the set's tests can show (orthotropy needs shear or biaxial tests)."""
        return catalogue(any(isinstance(t, PlaneSeries) for t in self.problem.tests))

    def variants(self, model: CandidateMaterial, cause: str) -> list[CandidateMaterial]:
        """``model`` with ``cause`` added (a viscoelasticity replacing the other), with both
        stiffening laws when the cause is stiffening. Anisotropy always has its oblique factor
        (the richer form holds the plainer one, and a form chosen early would be kept through
        later steps that it no longer suits), apart in compression as its El/Et is (tissue's
        shear term differs there: with one factor the tests at mid angles alone outweigh an
        asymmetry of every other test, and a plasticity stands in for it); the asymmetry is
        one factor on El and Et in compression (El and Et apart would also absorb the
        lattice's own difference between its anisotropy in tension and in compression, and
        name an asymmetry in every anisotropic set)."""
        causes = tuple(c for c in model.causes if not (c in EXCLUSIVE and cause in EXCLUSIVE))
        base = replace(model, causes=(*causes, cause))
        if cause == "strain_stiffening":
            return [replace(base, stiffening=law) for law in ("exponential", "polynomial")]
        return [base]

    def removed(self, model: CandidateMaterial, cause: str) -> CandidateMaterial:
        """``model`` without ``cause``; without its non-linear relaxation, with the linear
        one."""
        kept = tuple(c for c in model.causes if c != cause)
        if cause == EXCLUSIVE[1]:
            kept += (EXCLUSIVE[0],)
        return replace(model, causes=kept)

    def starts(self, base: Fit | None, cause: str | None) -> list[Start]:
        """The base's values; for a cause others absorb (a relaxation, the load cell's
        offset) added to a model with causes, the model's initial values too, and for the
        offset the compression terms at their tension twins (:func:`_mirrored`)."""
        starts = super().starts(base, cause)
        if cause in _ABSORBED and base is not None and base.model.causes:
            # The other causes' parameters, fitted without relaxation or without the
            # load cell's offset, may sit where they absorbed some of it: a fit from there
            # can stall far from the best, and the cause then looks to explain too little.
            starts.append(None)
            if cause == OFFSET:
                # An offset is followed by the compression terms (an anisotropy's oblique
                # factor in compression bent far from the tension one), and a fit from
                # there, or from none, stays in that basin.
                starts.append(_mirrored(base))
        return starts
