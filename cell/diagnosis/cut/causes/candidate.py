"""The cutting model of a cut diagnosis: the cut baseline plus causes of the cut catalogue
(:mod:`cell.diagnosis.cut.causes`, one module per cause), each a change to the cutting model
(or the blade's sensor) with the parameters a fit varies.

A :class:`CutCandidate` is the cut baseline (a constant toughness G, the plain cut) plus
some causes. The force on the blade is linear in G (per layer, with ``layered_toughness``), in
the faces' shear stress ``mu p`` and in the sensor's offset, so a fit solves for those in
closed form (:func:`linear_columns` gives the columns) and searches only the *shape*
parameters below.

==========================  ====================================================================
cause                       change (shape parameters; linear ones in brackets)
==========================  ====================================================================
``blade_friction``          the faces drag with ``mu p`` over the blade's area in the material
                            [``face_shear_pa``]
``slicing``                 the force to sink the edge falls with the slice/push ratio
                            (``slicing_efficiency``)
``rate_dependent_cutting``  G times ``(v / v_ref)^m`` (``rate_exponent``)
``indentation_stiffness``   the edge force ramps in over the first ``indentation_depth_m``
``layered_toughness``       G changes at depths below the top face (``layer_depth_{k}_m``)
                            [one toughness per layer]
``blade_force_offset``      the sensor reads a constant 3-vector [``offset_{x,y,z}_n``]
``edge_loading``            the edge loads the material over ``loading_depth_m`` past the crack
                            front before the crack runs; the load holds while the edge rests
``edge_friction``           the edge drags along itself with mu_e times its load, turning over
                            the slip ``edge_slip_m`` [``edge_friction_j_m2``: mu_e G]
``wedge_friction``          the blade wedges the cut open; the faces press with the modulus times
                            the opening strain and drag [``face_modulus_pa``: mu E]
==========================  ====================================================================

Example:
    >>> model = CutCandidate(("slicing", "layered_toughness"))
    >>> model.parameter_names
    ('slicing_efficiency', 'layer_depth_0_m')
    >>> model.linear_names
    ('toughness_0_j_m2', 'toughness_1_j_m2')
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cell.diagnosis.cut.causes.base import Parameter
from cell.diagnosis.cut.causes.registry import REGISTRY, catalogue
from cell.diagnosis.cut.reduced import CutKinematics
from cell.errors import DiagnosisError
from cell.tissue.cutmodel import CUT_CAUSES, CuttingParams, beef_cutting

__all__ = ["CUT_CAUSES", "FACE_PRESSURE_PA", "REPORTED_SPEED_M_S", "SOURCE_RANGES",
           "CutCandidate", "cause_of", "flat", "linear_columns", "source_checks"]
_AXES = ("x", "y", "z")
#: The faces' pressure that a fitted shear stress ``mu p`` is divided by, Pa, unless a
#: material says otherwise: the default beef's.
FACE_PRESSURE_PA = beef_cutting().face_pressure_pa
#: The edge speed at which a fitted toughness is given, m/s (the fit's own reference is the
#: set's typical speed, where the toughness is best determined): the default beef's.
REPORTED_SPEED_M_S = beef_cutting().reference_speed_m_s


@dataclass(frozen=True)
class CutCandidate:
    """The cut baseline plus ``causes`` (module docstring).

    Attributes:
        causes: causes of the catalogue (:data:`CUT_CAUSES` as it ships), in any order.
        reference_speed_m_s: v_ref of the rate factor (the set's typical edge speed), m/s.
        depth_m: the block's height, m: layer depths and the indentation lie within it.
        layers: layers of ``layered_toughness`` (one depth between each two).
        face_pressure_pa: the faces' pressure p that a fitted ``mu p`` is divided by.

    Raises:
        DiagnosisError: an unknown cause, fewer than two layers.

    Example:
        >>> CutCandidate(("rate_dependent_cutting",)).name
        'cut: constant toughness + rate_dependent_cutting'
    """

    causes: tuple[str, ...] = ()
    reference_speed_m_s: float = 0.01
    depth_m: float = 0.03
    layers: int = 2
    face_pressure_pa: float = FACE_PRESSURE_PA

    def __post_init__(self) -> None:
        causes = catalogue()
        unknown = set(self.causes) - set(causes)
        if unknown:
            raise DiagnosisError(None, "causes", f"unknown cut causes {sorted(unknown)}; the "
                                 f"catalogue is {causes}")
        if self.layers < 2:
            raise DiagnosisError(None, "layers", f"must be >= 2, got {self.layers}")
        object.__setattr__(self, "causes", tuple(c for c in causes if c in self.causes))

    @property
    def name(self) -> str:
        """A short description of the model."""
        return " + ".join(("cut: constant toughness", *self.causes))

    @property
    def has_offset(self) -> bool:
        """Whether the sensor's offset is fitted."""
        return "blade_force_offset" in self.causes

    @property
    def parameters(self) -> tuple[Parameter, ...]:
        """The shape parameters, each cause's in catalogue order, as its cause declares
        them."""
        return tuple(p for c in self.causes for p in REGISTRY[c].parameters(self))

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Names of the shape parameters, in vector order."""
        return tuple(p.name for p in self.parameters)

    @property
    def linear_names(self) -> tuple[str, ...]:
        """Names of the parameters solved in closed form, in column order: the toughness
        (the first layer's, with layers) and the other layers', the other causes', a sensor's
        offset last (:attr:`~cell.diagnosis.cut.causes.base.CutCause.column`)."""
        own = ("toughness_0_j_m2",) if "layered_toughness" in self.causes else ("toughness_j_m2",)
        causes = sorted(self.causes, key=lambda c: REGISTRY[c].column)
        return own + tuple(n for c in causes for n in REGISTRY[c].linear(self))

    @property
    def initial(self) -> np.ndarray:
        """A starting point for the shape parameters."""
        return np.array([p.initial for p in self.parameters])

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the shape parameters."""
        parameters = self.parameters
        return np.array([p.low for p in parameters]), np.array([p.high for p in parameters])

    def values(self, shape: np.ndarray) -> dict[str, float]:
        """The shape parameters by name."""
        return dict(zip(self.parameter_names, (float(v) for v in shape), strict=True))

    def unit_edge(self, shape: np.ndarray) -> tuple[CuttingParams, tuple[float, ...]]:
        """The model at unit toughness without layers, and the layer depths (sorted)."""
        value = self.values(shape)
        depths = tuple(sorted(value[n] for n in self.parameter_names
                              if n.startswith("layer_depth_")))
        fields = {"slicing_efficiency": 0.0, "rate_exponent": 0.0, "indentation_depth_m": 0.0,
                  "loading_depth_m": 0.0}
        for cause in self.causes:
            fields.update(REGISTRY[cause].fields(value))
        return CuttingParams(1.0, reference_speed_m_s=self.reference_speed_m_s, **fields), depths

    def cutting(self, shape: np.ndarray, linear: np.ndarray) -> CuttingParams:
        """The cutting model of ``shape`` and the linear parameters ``linear`` (no offset:
        the sensor's is not the material's)."""
        unit, depths = self.unit_edge(shape)
        solved = dict(zip(self.linear_names, (float(v) for v in linear), strict=True))
        toughness = [solved[n] for n in self.linear_names if n.startswith("toughness")]
        base = max(toughness[0], 1e-9)
        factors = tuple(max(g, 1e-9) / base for g in toughness) if depths else ()
        at_reported_speed = (REPORTED_SPEED_M_S / self.reference_speed_m_s) ** unit.rate_exponent
        return CuttingParams(base * at_reported_speed,
                             face_friction=solved.get("face_shear_pa", 0.0)
                             / self.face_pressure_pa, face_pressure_pa=self.face_pressure_pa,
                             slicing_efficiency=unit.slicing_efficiency,
                             reference_speed_m_s=REPORTED_SPEED_M_S,
                             rate_exponent=unit.rate_exponent,
                             indentation_depth_m=unit.indentation_depth_m,
                             layer_depths_m=depths, layer_factors=factors,
                             loading_depth_m=unit.loading_depth_m,
                             edge_friction=solved.get("edge_friction_j_m2", 0.0) / base,
                             edge_slip_m=unit.edge_slip_m,
                             face_modulus_pa=solved.get("face_modulus_pa", 0.0))

    def reported(self, shape: np.ndarray, linear: np.ndarray) -> dict[str, float]:
        """The fitted parameters in physical units, for people and the JSON report."""
        cutting = self.cutting(shape, linear)
        params = {"toughness_j_m2": cutting.toughness_j_m2}
        if "blade_friction" in self.causes:
            params["face_friction"] = cutting.face_friction
            params["face_pressure_pa"] = cutting.face_pressure_pa
        if "slicing" in self.causes:
            params["slicing_efficiency"] = cutting.slicing_efficiency
        if "rate_dependent_cutting" in self.causes:
            params["rate_exponent"] = cutting.rate_exponent
            params["reference_speed_m_s"] = cutting.reference_speed_m_s
        if "indentation_stiffness" in self.causes:
            params["indentation_depth_m"] = cutting.indentation_depth_m
        if "edge_loading" in self.causes:
            params["loading_depth_m"] = cutting.loading_depth_m
        if "edge_friction" in self.causes:
            params["edge_friction"] = cutting.edge_friction
            params["edge_slip_m"] = cutting.edge_slip_m
        if "wedge_friction" in self.causes:
            params["face_modulus_pa"] = cutting.face_modulus_pa
        for k, depth in enumerate(cutting.layer_depths_m):
            params[f"layer_depth_{k}_m"] = depth
        for k, factor in enumerate(cutting.layer_factors):
            params[f"layer_factor_{k}"] = factor
        solved = dict(zip(self.linear_names, (float(v) for v in linear), strict=True))
        params.update({f"blade_force_offset_{a}_n": solved[f"offset_{a}_n"] for a in _AXES
                       if self.has_offset})
        return params


#: The range each fitted parameter of a cause may take by its sources, (low, high, source);
#: (None, None, why) where no source bounds it, so that a report says so instead of passing it.
SOURCE_RANGES: dict[str, tuple[float | None, float | None, str]] = {
    "slicing_efficiency": (0.0, 1.0, "Atkins, Xu & Jeronimidis 2004: 1 is the ideal slice; "
                           "Reyssat et al. 2012 measured less"),
    "loading_depth_m": (None, None, "toughness over the stiffness under the edge (material "
                        "and rig): no published range for a rig"),
    "edge_friction": (None, None, "no published friction of an edge along itself in food"),
    "edge_slip_m": (None, None, "no published Dahl slip of an edge in food"),
    "face_modulus_pa": (2e3, 6e6, "mu E: friction of steel on moist food 0.2-0.6 (muscle "
                        "on bone 0.3, Shacham et al. 2010) times the modulus, 10 kPa (soft "
                        "muscle across its fibres, Van Loocke et al. 2006) to 10 MPa (firm "
                        "fruit and vegetable flesh)"),
}


def source_checks(params: dict[str, float]) -> list[dict[str, object]]:
    """Each fitted parameter of ``params`` that :data:`SOURCE_RANGES` names, with its range,
    source and whether it lies outside (None where no source bounds it).

    Example:
        >>> source_checks({"slicing_efficiency": 1.4, "toughness_j_m2": 90.0})[0]["outside"]
        True
    """
    checks = []
    for name, value in params.items():
        if name in SOURCE_RANGES:
            low, high, source = SOURCE_RANGES[name]
            outside = None if low is None or high is None else not low <= value <= high
            checks.append({"parameter": name, "value": value, "range": [low, high],
                           "source": source, "outside": outside})
    return checks


def cause_of(name: str, model: CutCandidate) -> str | None:
    """The cause of ``model`` that declares the fitted parameter ``name``
    (:attr:`CutCandidate.parameter_names`, :attr:`CutCandidate.linear_names`); None for the
    baseline's toughness (the first layer's, with layers).

    Example:
        >>> model = CutCandidate(("blade_friction", "layered_toughness"))
        >>> cause_of("toughness_1_j_m2", model), cause_of("face_shear_pa", model)
        ('layered_toughness', 'blade_friction')
        >>> cause_of("toughness_0_j_m2", model) is None
        True
    """
    for cause in model.causes:
        declared = REGISTRY[cause]
        if name in declared.linear(model) or any(p.name == name
                                                 for p in declared.parameters(model)):
            return cause
    return None


def flat(force_n: np.ndarray) -> np.ndarray:
    """An (n, 3) force as one series, channel after channel (x, then y, then z), so that a
    series' neighbours are neighbours in time."""
    return np.asarray(force_n).T.ravel()


def linear_columns(model: CutCandidate, shape: np.ndarray,
                   kinematics: CutKinematics) -> np.ndarray:
    """(3 n, k) the force of one test (:func:`flat`) per unit of each of ``model``'s linear
    parameters (:attr:`CutCandidate.linear_names`) at ``shape``."""
    unit, depths = model.unit_edge(shape)
    def in_layer(k: int) -> Callable[[np.ndarray], np.ndarray]:
        def factor(depth: np.ndarray) -> np.ndarray:
            layer = np.searchsorted(np.asarray(depths), depth, side="right")
            return unit.indentation_ramp(depth) * (layer == k)
        return factor

    rubbing = "edge_friction" in model.causes
    if rubbing:
        edge, rubbed = kinematics.edge_terms_n(unit, unit.indentation_ramp)
    if "layered_toughness" in model.causes:
        columns = [flat(kinematics.edge_n(unit, in_layer(k))) for k in range(model.layers)]
    else:
        columns = [flat(edge if rubbing else kinematics.edge_n(unit, unit.indentation_ramp))]
    if rubbing:
        # The friction of the whole load, at the first layer's toughness.
        columns.append(flat(rubbed))
    if "blade_friction" in model.causes:
        faces = CuttingParams(1.0, face_friction=1.0, face_pressure_pa=1.0)
        columns.append(flat(kinematics.faces_n(faces)))
    if "wedge_friction" in model.causes:
        columns.append(flat(kinematics.faces_n(CuttingParams(1.0, face_modulus_pa=1.0))))
    if model.has_offset:
        n = len(kinematics.middle_depth_m)
        columns += [np.repeat(np.eye(3)[k], n) for k in range(3)]
    return np.stack(columns, axis=1)
