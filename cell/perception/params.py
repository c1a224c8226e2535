"""How the cut is perceived (:class:`PerceptionParams`): the sensor's noise, the binning and the
curvature ball, the start marker's place and tolerance, and how the interface below the
guideline is estimated, with the settings of the walk, the floor and the fit.

Usage::

    perceive(rig, data, truth, generic_model(origin_m), PerceptionParams(bin_px=8), rng)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from cell.config import require_count, require_flag
from cell.errors import InputError
from cell.perception.floor import FloorParams
from cell.perception.guideline import GuidelineParams
from cell.perception.pointcloud import SensorNoise
from cell.perception.registration import FitParams


@dataclass(frozen=True)
class PerceptionParams:
    """How the cut is perceived (SI units).

    Attributes:
        enabled: whether the episode plans the knife from this perception (True) or from the
            generator's true top line and interface (False, the ground-truth baseline); read by
            the caller, :func:`perceive` itself always perceives.
        noise_sigma_at_1m_m: depth noise at 1 m, m (see
            :class:`~cell.perception.pointcloud.SensorNoise`).
        dropout_fraction: fraction of pixels without depth, in [0, 1).
        bin_px: the depth image is binned this many pixels square before meshing; 4 on the
            default 320 x 240 camera gives about the paper's mesh (1376 nodes).
        curvature_radius_m: radius of the curvature ball.
        marker_inset_m: the start marker's distance along the true top line from its first
            (-x) end, m.
        marker_tolerance_m: the most the perceived depth at the marker's pixel may differ from
            the marker's own depth for the marker to count as seen, m.
        interface: how the interface below the guideline is estimated: ``"seen"``
            (:class:`~cell.perception.interface.SeenInterface`: through the seen guideline,
            leaning as the generic model until later looks into the opened cut tell, chosen by
            measurement) or ``"affine"``
            (:class:`~cell.perception.predicted.PredictedInterface`: the affine fit's interface
            shifted onto the guideline).
        max_interface_lean: the steepest lean ``|dy/dz|`` the fitted interface may have below the
            guideline (the generator's shapes keep within 0.5). A top view leaves the fit's
            shears of height into y nearly free, and on meat far from the generic shape the
            fit uses them: its interface then leans tens of degrees and the knife would cut
            into a muscle, so such a fit is refused.
        guideline: how the valley is walked (:class:`~cell.perception.guideline.GuidelineParams`).
        floor: where the walked guideline finds the valley's floor on the unbinned cloud
            (:class:`~cell.perception.floor.FloorParams`).
        fit: how the generic model is fitted (:class:`~cell.perception.registration.FitParams`).

    Raises:
        InputError: a field out of range; ``field`` names it.

    Example:
        >>> PerceptionParams(bin_px=2).noise
        SensorNoise(sigma_at_1m_m=0.0015, dropout_fraction=0.02)
    """

    enabled: bool = True
    noise_sigma_at_1m_m: float = 1.5e-3
    dropout_fraction: float = 0.02
    bin_px: int = 4
    curvature_radius_m: float = 0.015
    marker_inset_m: float = 0.02
    marker_tolerance_m: float = 0.005
    max_interface_lean: float = 0.5
    interface: Literal["seen", "affine"] = "seen"
    guideline: GuidelineParams = field(default_factory=GuidelineParams)
    floor: FloorParams = field(default_factory=FloorParams)
    fit: FitParams = field(default_factory=FitParams)

    def __post_init__(self) -> None:
        require_flag(self, "enabled")
        if not self.noise_sigma_at_1m_m >= 0.0:
            raise InputError(None, "noise_sigma_at_1m_m",
                             f"must be >= 0, got {self.noise_sigma_at_1m_m}")
        if not 0.0 <= self.dropout_fraction < 1.0:
            raise InputError(None, "dropout_fraction",
                             f"must be in [0, 1), got {self.dropout_fraction}")
        require_count(self, "bin_px", 1)
        for name in ("curvature_radius_m", "marker_tolerance_m", "max_interface_lean"):
            if not getattr(self, name) > 0.0:
                raise InputError(None, name, f"must be > 0, got {getattr(self, name)}")
        if not self.marker_inset_m >= 0.0:
            raise InputError(None, "marker_inset_m", f"must be >= 0, got {self.marker_inset_m}")
        if self.interface not in ("seen", "affine"):
            raise InputError(None, "interface",
                             f"must be 'seen' or 'affine', got {self.interface!r}")
        if not isinstance(self.guideline, GuidelineParams):
            raise InputError(None, "guideline", "must be a GuidelineParams")
        if not isinstance(self.floor, FloorParams):
            raise InputError(None, "floor", "must be a FloorParams")
        if not isinstance(self.fit, FitParams):
            raise InputError(None, "fit", "must be a FitParams")

    @property
    def noise(self) -> SensorNoise:
        """The sensor model these parameters describe."""
        return SensorNoise(self.noise_sigma_at_1m_m, self.dropout_fraction)
