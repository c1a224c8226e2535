"""The procedural shape of the round and the shank side by side (:class:`MuscleShape`): their
dimensions, the valley between them, the interface's bow and lean, and the mesh resolution.

Frame: x along the muscles, z up from the table, the round at y < 0 and the shank at y > 0; the
origin is the middle of the interface at table level. Each muscle's top dips into the valley at
the interface and rounds off towards its vertical outer wall; the ends taper.
:func:`~cell.tissue.geometry.build_two_muscles` meshes it.

Example:
    >>> shape = MuscleShape(valley_depth_m=0.02)
    >>> round(shape.interface_top_m, 3)  # the lower crest less the valley, m
    0.07
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Literal

import numpy as np

from cell.config import MUSCLE_SIZE_M
from cell.errors import InputError

# The rounded top edge turns the top down by this much before it meets the vertical outer wall:
# a mapped grid needs a corner there, and 135 degrees keeps the corner cells well shaped (a full
# quarter round makes a flat corner and slivers).
_EDGE_SWEEP_RAD = math.radians(45.0)
# The derived valley width: the default shape's 0.03 m, or 1.15 times the valley's rise where
# that is wider (the walls then stay below 37 degrees, the 45 the mesh allows with margin).
_VALLEY_WIDTH_M = 0.03
_VALLEY_WIDTH_PER_RISE = 1.15

Muscle = Literal["round", "shank"]
"""Which of the two muscles: the round lies at y < 0, the shank at y > 0."""


@dataclass(frozen=True)
class MuscleShape:
    """Dimensions of the two-muscle specimen and its mesh resolution (SI units).

    Attributes:
        length_m: length along x of both muscles.
        round_width_m: width of the round (y < 0), from the interface middle to its outer wall.
        shank_width_m: width of the shank (y > 0), likewise.
        round_height_m: crest height of the round above the table.
        shank_height_m: crest height of the shank above the table.
        interface_bow_m: in plan view the interface bows towards the shank by this much in the
            middle relative to its ends (negative bows towards the round).
        interface_lean: slope dy/dz of the interface (dimensionless, within +-0.5): it leans
            towards the shank as it rises when positive.
        valley_depth_m: how far the top edge of the interface lies below the crest of the lower
            muscle: the valley the cut follows.
        valley_width_m: lateral decay length of the valley on each side; at least 0.86 times
            the rise from the interface top to the higher crest, so no wall passes 45 degrees.
            None (the default) derives it from the shape (:attr:`valley_decay_m`): 0.03 m, or
            1.15 times the rise where that is wider.
        edge_radius_m: radius of the rounded top edge along each outer wall: a circular arc
            that turns the top down by 45 degrees, dropping it 0.29 times this, before the
            vertical wall.
        end_taper: fraction of the height lost at the two ends, in [0, 0.6] (0 keeps it
            constant along x).
        gap_m: distance along y between facing vertices of the two muscles (they never touch).
        cell_size_m: target edge length of the structured grid; the counts are rounded up
            (of a scan's tets: their largest edge, about).
        surface_mesh: closed surface files of a scanned or segmented pair of muscles
            (:mod:`cell.tissue.scan`): two, the round's then the shank's, or one that holds
            both as separate bodies. Given, they replace the procedural shape, whose
            dimensions are then unused.
        interface_tolerance_m: a scan's vertex lies on the interface when it is within this
            distance of the other muscle's surface.

    Raises:
        InputError: a field out of range; ``field`` names it.

    Example:
        >>> MuscleShape(cell_size_m=0.05).cell_counts()
        (9, 3, 3, 2)
    """

    length_m: float = 0.45
    round_width_m: float = 0.13
    shank_width_m: float = 0.11
    round_height_m: float = 0.10
    shank_height_m: float = 0.09
    interface_bow_m: float = 0.02
    interface_lean: float = 0.1
    valley_depth_m: float = 0.015
    valley_width_m: float | None = None
    edge_radius_m: float = 0.05
    end_taper: float = 0.25
    gap_m: float = 0.003
    cell_size_m: float = 0.025
    surface_mesh: tuple[str, ...] = ()
    interface_tolerance_m: float = 0.005

    def __post_init__(self) -> None:
        if len(self.surface_mesh) > 2 or not all(isinstance(name, str)
                                                 for name in self.surface_mesh):
            raise InputError(None, "surface_mesh",
                             f"must be one or two file names, got {self.surface_mesh!r}")
        for f in fields(self):
            if f.name == "surface_mesh" or (f.name == "valley_width_m"
                                            and self.valley_width_m is None):
                continue
            value = getattr(self, f.name)
            if not isinstance(value, int | float) or isinstance(value, bool):
                raise InputError(None, f.name, f"must be a number, got {value!r}")
            if not math.isfinite(value):
                raise InputError(None, f.name, f"must be finite, got {value}")
        for name in (
            "length_m",
            "round_width_m",
            "shank_width_m",
            "round_height_m",
            "shank_height_m",
            "valley_decay_m",
            "edge_radius_m",
            "gap_m",
            "cell_size_m",
            "interface_tolerance_m",
        ):
            if getattr(self, name) <= 0.0:
                key = "valley_width_m" if name == "valley_decay_m" else name
                raise InputError(None, key, f"must be > 0, got {getattr(self, name)}")
        if not self.surface_mesh:
            self._check_size()
        lower = min(self.round_height_m, self.shank_height_m)
        edge_drop = self.edge_radius_m * (1.0 - math.cos(_EDGE_SWEEP_RAD))
        if not 0.0 <= self.valley_depth_m < lower - edge_drop:
            raise InputError(
                None,
                "valley_depth_m",
                f"must be in [0, {lower - edge_drop:.4g}) (the lower height less the drop of "
                f"the rounded edge), got {self.valley_depth_m}",
            )
        # Steeper valley walls than 45 degrees shear the mapped cells into slivers; the
        # steepest slope of the valley profile is rise * sqrt(2 / e) / valley_width_m.
        rise = max(self.round_height_m, self.shank_height_m) - self.interface_top_m
        narrowest_valley = rise * math.sqrt(2.0 / math.e)
        if self.valley_decay_m < narrowest_valley:
            raise InputError(
                None,
                "valley_width_m",
                f"must be >= {narrowest_valley:.4g} so that no valley wall is steeper than "
                f"45 degrees (it rises {rise:.4g} m), got {self.valley_width_m}",
            )
        if not 0.0 <= self.end_taper <= 0.6:
            raise InputError(None, "end_taper", f"must be in [0, 0.6], got {self.end_taper}")
        if abs(self.interface_lean) > 0.5:
            raise InputError(
                None, "interface_lean", f"must be within [-0.5, 0.5], got {self.interface_lean}"
            )
        # The narrowest plan width, where bow and lean both eat into a muscle, must still hold
        # the rounded edge beside the interface.
        edge_run = self.edge_radius_m * math.sin(_EDGE_SWEEP_RAD)
        for name in ("round_width_m", "shank_width_m"):
            narrowest = (
                getattr(self, name)
                - abs(self.interface_bow_m)
                - abs(self.interface_lean) * max(self.round_height_m, self.shank_height_m)
                - self.gap_m / 2.0
            )
            if narrowest <= edge_run:
                raise InputError(
                    None,
                    name,
                    f"leaves {narrowest:.4g} m where bow and lean narrow it, not more than "
                    f"the {edge_run:.4g} m the rounded edge takes",
                )

    def _check_size(self) -> None:
        """Named here what fails later without a name: a muscle too small for the camera to
        find its marker, cells too coarse to hold the valley the guideline follows."""
        sizes = ("length_m", "round_width_m", "shank_width_m", "round_height_m",
                 "shank_height_m")
        for name in sizes:
            MUSCLE_SIZE_M.check(getattr(self, name), None, name)
        thinnest = min(sizes[1:], key=lambda name: getattr(self, name))
        if self.cell_size_m > getattr(self, thinnest):
            raise InputError(None, "cell_size_m", f"{self.cell_size_m} m is coarser than "
                             f"{thinnest} ({getattr(self, thinnest)} m): one cell across "
                             "cannot hold the valley the cut follows")

    def cell_counts(self) -> tuple[int, int, int, int]:
        """Cells along x, across the round, across the shank and up (shared by both).

        Example:
            >>> MuscleShape().cell_counts()
            (18, 6, 5, 4)
        """

        def count(extent_m: float) -> int:
            # A hair of slack keeps exact multiples (0.45 / 0.025) from rounding up a cell.
            return max(1, math.ceil(extent_m / self.cell_size_m - 1e-9))

        return (
            count(self.length_m),
            count(self.round_width_m - self.gap_m / 2.0),
            count(self.shank_width_m - self.gap_m / 2.0),
            count(max(self.round_height_m, self.shank_height_m)),
        )

    @property
    def valley_decay_m(self) -> float:
        """The valley's lateral decay length in use, m: ``valley_width_m`` where given, else
        derived from the rise from the interface top to the higher crest.

        Example:
            >>> MuscleShape().valley_decay_m  # a rise of 0.025 m
            0.03
            >>> round(MuscleShape(round_height_m=0.13).valley_decay_m, 4)  # 0.055 m
            0.0633
        """
        if self.valley_width_m is not None:
            return self.valley_width_m
        rise = max(self.round_height_m, self.shank_height_m) - self.interface_top_m
        return max(_VALLEY_WIDTH_M, _VALLEY_WIDTH_PER_RISE * rise)

    @property
    def interface_top_m(self) -> float:
        """Height of the interface's top edge above the table in the middle, in m."""
        return min(self.round_height_m, self.shank_height_m) - self.valley_depth_m

    def interface_y_m(self, x_m: np.ndarray, z_m: np.ndarray) -> np.ndarray:
        """y of the interface mid-surface at (x, z), in the local frame (origin at its middle).

        Example:
            >>> float(MuscleShape().interface_y_m(np.array(0.0), np.array(0.0)))
            0.0
        """
        s = 2.0 * np.asarray(x_m) / self.length_m
        return -self.interface_bow_m * s**2 + self.interface_lean * np.asarray(z_m)

    def side_of(self, muscle: Muscle) -> tuple[int, float, float]:
        """Direction in y (-1 round, +1 shank), width (m) and crest height (m) of ``muscle``."""
        if muscle == "round":
            return -1, self.round_width_m, self.round_height_m
        if muscle == "shank":
            return 1, self.shank_width_m, self.shank_height_m
        raise InputError(None, "muscle", f"must be 'round' or 'shank', got {muscle!r}")

    def plan_width_m(self, muscle: Muscle, x_m: np.ndarray) -> np.ndarray:
        """Width of ``muscle`` at table level at x (local frame), interface face to outer wall.

        Example:
            >>> round(float(MuscleShape().plan_width_m("shank", np.array(0.225))), 4)
            0.1285
        """
        side, width, _ = self.side_of(muscle)
        return width - side * self.interface_y_m(x_m, 0.0) - self.gap_m / 2.0

    def top_z_m(self, muscle: Muscle, x_m: np.ndarray, d_m: np.ndarray) -> np.ndarray:
        """Height of the top surface of ``muscle`` at x and lateral coordinate d, in m.

        d in [0, plan_width_m] is the distance from the muscle's interface face at table level;
        the top point it names lies the same fraction d / plan_width_m of the way from the
        interface face to the outer wall at its own height (they differ where the interface
        leans). The top dips to ``interface_top_m`` at d = 0 (the valley) and rounds off with
        ``edge_radius_m`` at the outer wall.

        Example:
            >>> shape = MuscleShape()
            >>> float(shape.top_z_m("round", np.array(0.0), np.array(0.0))) == shape.interface_top_m
            True
        """
        _, _, height = self.side_of(muscle)
        x_m = np.asarray(x_m)
        d_m = np.asarray(d_m)
        low = self.interface_top_m
        # Both muscles end at exactly ``low`` at d = 0, so facing vertices get the same z.
        profile = low + (height - low) * -np.expm1(-((d_m / self.valley_decay_m) ** 2))
        radius = self.edge_radius_m
        run = radius * math.sin(_EDGE_SWEEP_RAD)
        t = np.clip(d_m - (self.plan_width_m(muscle, x_m) - run), 0.0, run)
        profile = profile - (radius - np.sqrt(radius**2 - t**2))
        return profile * (1.0 - self.end_taper * (2.0 * x_m / self.length_m) ** 2)
