"""What one cause of the cut catalogue is (:class:`CutCause`): its name, the shape parameters
it adds to a cutting model with their initial values and bounds, the parameters it adds that a
fit solves in closed form, and the fields of the unit cutting model it sets.

Usage::

    class Dulling(CutCause):
        name = "dulling"
        def parameters(self, model): return (Parameter("dulling_m", 0.0, 0.0, 1e-3),)
"""

from __future__ import annotations

from typing import Any, ClassVar, Protocol

from cell.diagnosis.specimen.causes.base import Parameter

__all__ = ["CutCause", "CutSettings", "Parameter"]


class CutSettings(Protocol):
    """The cutting model's settings a cause's parameters depend on
    (:class:`~cell.diagnosis.cut.causes.candidate.CutCandidate`)."""

    depth_m: float
    layers: int


class CutCause:
    """A cause of the cut catalogue: a change to the cutting model or the blade's sensor. A
    subclass sets ``name`` and overrides what it changes; the force columns of the linear
    parameters are built by :func:`~cell.diagnosis.cut.causes.candidate.linear_columns`.

    Attributes:
        column: where its linear parameters go among a model's: 0 with the toughness, 1
            after it, 2 last (a sensor's offset).
        needs_sliding: whether it acts only while the edge slides along itself (nothing on a
            press cut), so that only the tests that saw show it.

    Example:
        >>> CutCause().linear(None)
        ()
    """

    name: ClassVar[str] = ""
    column: ClassVar[int] = 1
    needs_sliding: ClassVar[bool] = False

    def parameters(self, model: CutSettings) -> tuple[Parameter, ...]:
        """The shape parameters the cause adds to ``model``, in vector order."""
        return ()

    def linear(self, model: CutSettings) -> tuple[str, ...]:
        """The names of the parameters it adds that a fit solves in closed form."""
        return ()

    def fields(self, value: dict[str, float]) -> dict[str, Any]:
        """The unit :class:`~cell.tissue.cutmodel.CuttingParams` fields it sets from the
        shape parameters by name (``value``)."""
        return {}
