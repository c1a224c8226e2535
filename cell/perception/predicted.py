"""The interface an affine fit of the generic model predicts, placed on the seen valley
(``PerceptionParams.interface = "affine"``).

Example:
    >>> from cell.perception.pipeline import generic_model
    >>> from cell.perception.registration import AffineFit
    >>> generic = generic_model((0.0, 0.0, 0.6))
    >>> unmoved = AffineFit(np.eye(3), np.zeros(3), np.zeros(3), 0.0)
    >>> interface_y = PredictedInterface(unmoved, generic, generic.top_line)
    >>> bool(np.allclose(interface_y(generic.top_line[:, 0], generic.top_line[:, 2]),
    ...                  generic.top_line[:, 1]))
    True
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell.errors import PerceptionError
from cell.perception.registration import AffineFit
from cell.tissue.geometry import TwoMuscleMesh

# Solving y(x, z) on the fitted interface: each round shrinks the error by the surface's slope
# across y in the model's frame (a hundredth for fits within a few degrees of the nominal pose).
_INTERFACE_ROUNDS = 50
_INTERFACE_TOLERANCE_M = 1e-10
# Height step over which the predicted interface's lean is measured below the guideline, m.
_LEAN_STEP_M = 0.01


@dataclass(frozen=True, eq=False)
class PredictedInterface:
    """The interface as the surface y(x, z), world frame, m: the callable that
    :func:`controllers.knife.plan_cut` takes as ``interface_y``.

    Its shape below the surface is the fitted model's: the generic model's own interface
    mid-surface (:meth:`~cell.tissue.geometry.TwoMuscleMesh.interface_y`) mapped by the fit, in
    closed form, so it extends past the meat's ends where the knife enters and leaves
    (:func:`~cell.perception.registration.predict_interface` samples the same surface at the model's
    facing pairs). Its place is the seen valley's: at each x it is shifted along y to pass
    through the guideline. The camera sees the interface's top edge directly, while an affine
    fit of the generic shape to meat of another shape places it millimetres to centimetres off
    (heights and the interface's bow do not map affinely); below the top, the fit's lean is
    all there is to go on.

    Attributes:
        fit: the fitted affine map of the generic model.
        model: the generic model.
        anchor_m: (K, 3) the guideline the surface passes through, m.

    Example:
        >>> from cell.perception.registration import AffineFit
        >>> from cell.perception.pipeline import generic_model
        >>> generic = generic_model((0.0, 0.0, 0.6))
        >>> unmoved = AffineFit(np.eye(3), np.zeros(3), np.zeros(3), 0.0)
        >>> interface_y = PredictedInterface(unmoved, generic, generic.top_line + [0.0, 0.002, 0.0])
        >>> x_m, z_m = np.array([0.0]), np.array([0.62])
        >>> bool(np.isclose(interface_y(x_m, z_m) - interface_y.fitted_y(x_m, z_m), 0.002))
        True
    """

    fit: AffineFit
    model: TwoMuscleMesh
    anchor_m: np.ndarray

    def fitted_y(self, x_m: np.ndarray, z_m: np.ndarray) -> np.ndarray:
        """World y (m) of the fitted model's interface at world (x, z) (m), not shifted onto
        the guideline; broadcasts.

        Raises:
            PerceptionError: the fitted surface is not a function of (x, z) there (a fit
                turned so far that the interface faces along x or z).
        """
        x, z = np.broadcast_arrays(np.asarray(x_m, dtype=float), np.asarray(z_m, dtype=float))
        inverse = np.linalg.inv(self.fit.matrix)
        pivot = self.fit.pivot_m
        # The world point (x, y, z) maps back to q = q0 + y a in the model's frame, and lies on
        # the interface where q_y equals the model's interface y at (q_x, q_z).
        world = np.stack([x, np.zeros_like(x), z], axis=-1)
        q0 = (world - pivot - self.fit.translation_m) @ inverse.T + pivot
        along = inverse[:, 1]
        y = np.zeros_like(x)
        for _ in range(_INTERFACE_ROUNDS):
            q = q0 + y[..., None] * along
            residual = q[..., 1] - self.model.interface_y(q[..., 0], q[..., 2])
            y = y - residual / along[1]
            if np.all(np.abs(residual) <= _INTERFACE_TOLERANCE_M):
                return y
        raise PerceptionError(
            "the fitted interface is not a surface y(x, z) at the points asked: the fit turned "
            "the generic model too far from its nominal pose")

    def __call__(self, x_m: np.ndarray, z_m: np.ndarray) -> np.ndarray:
        """World y (m) of the interface at world (x, z) (m); broadcasts. Past the guideline's
        ends the shift of its nearest end holds.

        Raises:
            PerceptionError: as :meth:`fitted_y`.
        """
        x = np.asarray(x_m, dtype=float)
        order = np.argsort(self.anchor_m[:, 0])
        anchor_x, anchor_y, anchor_z = self.anchor_m[order].T
        shift_y = anchor_y - self.fitted_y(anchor_x, anchor_z)
        return self.fitted_y(x, z_m) + np.interp(x, anchor_x, shift_y)



def refuse_leaning(interface_y: PredictedInterface, guideline_m: np.ndarray,
                    max_lean: float) -> None:
    """PerceptionError where the fitted interface leans more than ``max_lean`` (``|dy/dz|``)
    below the guideline's points (K, 3), m."""
    x, _, z = guideline_m.T
    lean = (interface_y.fitted_y(x, z) - interface_y.fitted_y(x, z - _LEAN_STEP_M)) / _LEAN_STEP_M
    if np.max(np.abs(lean)) > max_lean:
        raise PerceptionError(
            f"the fitted model's interface leans up to {np.max(np.abs(lean)):.2f} (|dy/dz|) "
            f"below the guideline, more than {max_lean}: the view does not "
            "pin down this meat's shape, and the knife would cut into a muscle")
