"""Scenario files: one TOML file describes one scripted cutting episode.

Every table maps onto a parameter dataclass; a wrong key, type or value raises
:class:`~cell.errors.ScenarioError` naming the file and the dotted key.

Example:
    >>> scenario = load_scenario("scenarios/default.toml")
    >>> scenario.cut.speed_m_s
    0.03
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Literal

from cell.assets import asset_path
from cell.config import from_table, read_toml, require_non_negative, require_positive
from cell.errors import InputError, MaterialError, ScenarioError
from cell.perception.params import PerceptionParams
from cell.robots.choice import PLACES, ArmsParams, cell_arm
from cell.robots.tools import CameraParams, FixtureParams, GripperParams, KnifeParams
from cell.tissue.aponeurosis import ReleaseRule
from cell.tissue.cutmodel import CuttingParams
from cell.tissue.geometry import MuscleShape
from cell.tissue.material import ContinuumMaterial, MassSpringMaterial, default_meat
from cell.tissue.materialfile import load_material, material_from_table
from controllers.gripper import PullPlan
from controllers.knife import CutPlan
from controllers.steering import SteeringParams

#: Data files named ``assets/...`` in a scenario that are not beside it come from the package.
_ASSETS_PREFIX = "assets/"


@dataclass(frozen=True)
class SimulationParams:
    """Physics settings. ``timestep_s`` is MuJoCo's step; the controllers run at
    ``control_rate_hz``, every :attr:`control_substeps` physics steps, and the implicit step
    runs the spring law once per control step; ``max_tissue_speed_m_s`` flags an energy
    blow-up. ``tissue_step``: how the mass-spring springs are integrated: ``"implicit"`` (the
    default, :mod:`cell.tissue.implicit`: stable at any stiffness, so the step is set by
    accuracy and by the contacts and the arms, whose servos are sized by
    :class:`~cell.robots.servos.ServoTuning` and come near the explicit limit of their own
    integration as the step grows: docs/benchmarks.md gives the default's margin) or
    ``"explicit"`` (MuJoCo's explicit step of the spring forces, refused above the springs'
    stable step, :meth:`~cell.tissue.massspring.MassSpringModel.stable_timestep_s`, which
    shrinks as the meat stiffens or the mesh refines). ``integrator``
    ``"auto"`` picks ``discrete`` for continuum materials (the only one MuJoCo runs them
    with) and ``implicitfast`` for the mass-spring model (``euler`` in a scene without the
    arms: :func:`~cell.sim.assembly.integrator`). ``muscle_contact`` lets the two
    muscles collide with each other (off by default: it makes a step much dearer, and the
    bindings and the pull keep them apart).

    Example:
        >>> SimulationParams().timestep_s, SimulationParams().tissue_step
        (0.005, 'implicit')
        >>> SimulationParams(timestep_s=0.0025).control_substeps  # 20 ms / 2.5 ms
        8
        >>> SimulationParams(control_rate_hz=1000.0)
        Traceback (most recent call last):
        cell.errors.InputError: control_rate_hz: faster than the physics step
    """

    timestep_s: float = 0.005
    control_rate_hz: float = 50.0
    integrator: Literal["auto", "discrete", "implicitfast", "euler"] = "auto"
    tissue_step: Literal["implicit", "explicit"] = "implicit"
    muscle_contact: bool = False
    solver_iterations: int = 100
    max_tissue_speed_m_s: float = 20.0
    table_friction: float = 0.6
    tissue_friction: float = 0.5

    def __post_init__(self) -> None:
        require_positive(self, "timestep_s", "control_rate_hz", "solver_iterations",
                  "max_tissue_speed_m_s", "table_friction", "tissue_friction")
        if self.control_rate_hz * self.timestep_s > 1.0:
            raise InputError(None, "control_rate_hz", "faster than the physics step")

    @property
    def control_substeps(self) -> int:
        """Physics steps per control step: the control period over ``timestep_s``, rounded to
        the nearest whole number (at least 1). The episode steps the physics this many times
        per control step, and the implicit step runs the spring law once in them."""
        return max(1, round((1.0 / self.control_rate_hz) / self.timestep_s))


@dataclass(frozen=True)
class AponeurosisParams:
    """Bindings across the interface and how they release.

    ``law``: ``"spring"`` (the paper's binding springs: ``stiffness_n_m``, paper 50 N/m, and a
    dashpot ``damping_n_s_m``) or ``"constraint"`` (soft MuJoCo ``connect`` equalities with
    ``timeconst_s`` and ``dampratio``, whose stiffness scales with the vertex masses).
    ``release_rules``: any of ``"knife"``, ``"tearing"`` and ``"force"``.
    ``tearing_stretch_m``: stretch beyond rest length that tears a binding (paper: 1e-2 m);
    ``tearing_force_n``: a pull-off strength that tears it too (0: none).
    ``knife_margin_m``: how far beyond the blade box a binding counts as under the blade.
    ``knife_force``: where the knife's cutting force comes from. ``"cutting"`` (the default):
    the material's cutting model (its ``[cutting]`` table, :mod:`cell.tissue.cutmodel`) with
    the seam's toughness ``toughness_j_m2`` (J/m^2: the edge cuts aponeurosis, not muscle),
    on the length of edge in uncut seam and the blade's area in the meat, from the geometry
    (:class:`~cell.tissue.seamcut.SeamCut`); a material without a ``[cutting]`` table gets
    the plain cut (the toughness alone). ``"curve"``: a measured cutting force against time,
    ``force_curve`` (CSV, path relative to the scenario file, or ``assets/...`` for the
    package's own data), of which the blade's edge meets ``edge_share`` in the flesh while
    the knife cuts (:class:`~cell.tissue.cutting.EdgeResistance`; 0: none), the releases
    before this option. ``force_share``: the fraction of the cutting force (the model's force
    to push the edge through the seam, or the curve's) one binding under the blade must
    carry to be cut by the force rule (the knife force also shears muscle and overcomes
    friction); ``force_scale`` multiplies the cutting force (the seam's toughness or the
    curve: a duller or sharper knife, a tougher or weaker aponeurosis).
    ``toughness_gradient``: the seam's toughness graded along the interface (the cutting
    model only): times ``exp(g (x - x_mid) / L)`` at the blade's centre ``x``, ``x_mid`` the
    interface's middle and ``L`` its length, so that ``exp(g)`` is the ratio of its toughness
    at the +x end to the -x end (0: the same all along). ``force_share`` and
    ``edge_share`` were chosen on the default episode with the curve so that the force rule
    cuts the bindings within the blade's reach and the pull tears those below it, and the
    knife reads about the curve's force while cutting (docs/benchmarks.md gives the
    measurements); docs/simulation.md gives the seam's toughness and its sources.

    Example:
        >>> AponeurosisParams(release_rules=("knife",)).tearing_stretch_m
        0.01
        >>> AponeurosisParams(law="constraint", release_rules=("force",))
        Traceback (most recent call last):
        cell.errors.InputError: release_rules: the force rule needs law = "spring" ...
    """

    law: Literal["spring", "constraint"] = "spring"
    stiffness_n_m: float = 50.0
    damping_n_s_m: float = 0.5
    release_rules: tuple[str, ...] = ("force", "tearing")
    tearing_stretch_m: float = 0.01
    tearing_force_n: float = 0.0
    timeconst_s: float = 0.01
    dampratio: float = 1.0
    knife_margin_m: float = 0.003
    knife_force: Literal["cutting", "curve"] = "cutting"
    toughness_j_m2: float = 170.0
    toughness_gradient: float = 0.0
    force_curve: str = str(asset_path("cutting_force/boning_knife_synthetic.csv"))
    force_share: float = 0.05
    force_scale: float = 1.0
    edge_share: float = 0.8

    def __post_init__(self) -> None:
        known = sorted(rule.value for rule in ReleaseRule)
        for rule in self.release_rules:
            if rule not in known:
                raise InputError(None, "release_rules", f"unknown rule {rule!r}; known: {known}")
        require_positive(self, "stiffness_n_m", "tearing_stretch_m", "timeconst_s", "dampratio",
                  "force_share", "force_scale", "toughness_j_m2")
        require_non_negative(self, "damping_n_s_m", "tearing_force_n", "knife_margin_m",
                             "edge_share")
        if not math.isfinite(self.toughness_gradient):
            raise InputError(None, "toughness_gradient", "expected a finite number")
        if "force" in self.release_rules and self.law != "spring":
            raise InputError(None, "release_rules",
                             "the force rule needs law = \"spring\" (a binding force in N)")

    def cutting(self, material: CuttingParams | None) -> CuttingParams:
        """The cutting model the knife meets in the seam: the material's (``material``, its
        ``[cutting]`` table; None: the plain cut) with the seam's toughness times
        ``force_scale``.

        Example:
            >>> AponeurosisParams(force_scale=2.0).cutting(None).toughness_j_m2
            340.0
        """
        toughness = self.toughness_j_m2 * self.force_scale
        if material is None:
            return CuttingParams(toughness_j_m2=toughness)
        return replace(material, toughness_j_m2=toughness)


@dataclass(frozen=True)
class LayoutParams:
    """Where things stand in the cell (world frame, m; yaw about z in degrees).

    Example:
        >>> LayoutParams(table_height_m=0.7).meat_origin_m
        (0.0, 0.0, 0.7)
    """

    table_height_m: float = 0.6
    meat_x_m: float = 0.0
    knife_arm_base: tuple[float, float, float, float] = (0.0, -0.85, 0.0, 90.0)
    pull_arm_base: tuple[float, float, float, float] = (0.0, 0.95, 0.0, -90.0)
    camera_arm_base: tuple[float, float, float, float] = (0.55, 0.30, 0.6, 180.0)

    def __post_init__(self) -> None:
        require_positive(self, "table_height_m")

    @property
    def meat_origin_m(self) -> tuple[float, float, float]:
        """Where the fixture holds the meat: the middle of its interface on the table, m."""
        return (self.meat_x_m, 0.0, self.table_height_m)


@dataclass(frozen=True)
class SensorParams:
    """Sensor noise (standard deviations, drawn from the scenario's seed) and bias (what taring
    leaves: a drift added to every force reading, N, or torque reading, N m, sensor frame).

    Example:
        >>> SensorParams(force_noise_n=0.0).torque_noise_nm
        0.005
        >>> SensorParams(force_bias_n=(0.2, 0.0, -0.1)).torque_bias_nm
        (0.0, 0.0, 0.0)
    """

    force_noise_n: float = 0.05
    torque_noise_nm: float = 0.005
    force_bias_n: tuple[float, float, float] = (0.0, 0.0, 0.0)
    torque_bias_nm: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        require_non_negative(self, "force_noise_n", "torque_noise_nm")


@dataclass(frozen=True)
class RecordingParams:
    """What the Rerun recording keeps: scene frames at ``rate_hz``, camera images at
    ``camera_rate_hz``.

    Example:
        >>> RecordingParams(camera_rate_hz=5.0).rate_hz
        20.0
    """

    rate_hz: float = 20.0
    camera_rate_hz: float = 2.0

    def __post_init__(self) -> None:
        require_positive(self, "rate_hz", "camera_rate_hz")


@dataclass(frozen=True)
class Scenario:
    """One scripted episode: the cell, the meat, and the plan.

    Example:
        >>> from cell.tissue.geometry import MuscleShape
        >>> quick = Scenario(name="quick", tissue=MuscleShape(cell_size_m=0.05))
        >>> quick.tissue.cell_size_m, quick.cut.speed_m_s
        (0.05, 0.03)
    """

    name: str = "default"
    seed: int = 0
    settle_s: float = 0.3
    end_s: float | None = None
    simulation: SimulationParams = field(default_factory=SimulationParams)
    tissue: MuscleShape = field(default_factory=MuscleShape)
    material: ContinuumMaterial | MassSpringMaterial = field(default_factory=default_meat)
    aponeurosis: AponeurosisParams = field(default_factory=AponeurosisParams)
    knife: KnifeParams = field(default_factory=KnifeParams)
    fixture: FixtureParams = field(default_factory=FixtureParams)
    gripper: GripperParams = field(default_factory=GripperParams)
    camera: CameraParams = field(default_factory=CameraParams)
    cut: CutPlan = field(default_factory=CutPlan)
    pull: PullPlan = field(default_factory=PullPlan)
    steering: SteeringParams = field(default_factory=SteeringParams)
    layout: LayoutParams = field(default_factory=LayoutParams)
    arms: ArmsParams = field(default_factory=ArmsParams)
    sensors: SensorParams = field(default_factory=SensorParams)
    perception: PerceptionParams = field(default_factory=PerceptionParams)
    recording: RecordingParams = field(default_factory=RecordingParams)


@dataclass(frozen=True)
class _Head:
    name: str = "default"
    seed: int = 0
    settle_s: float = 0.3
    end_s: float | None = None

    def __post_init__(self) -> None:
        require_positive(self, "settle_s")
        require_non_negative(self, "seed")
        if self.end_s is not None:
            require_positive(self, "end_s")


_TABLES = ("simulation", "tissue", "material", "aponeurosis", "knife", "fixture", "gripper",
           "camera", "cut", "pull", "steering", "layout", "arms", "sensors", "perception",
           "recording")


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario TOML file.

    The file has a ``[scenario]`` table (name, seed, settle_s, end_s) and one table per
    :class:`Scenario` field; every table and key is optional and takes the defaults.
    """
    path = Path(path)
    raw = read_toml(path)
    unknown = set(raw) - {"scenario", *_TABLES}
    if unknown:
        raise ScenarioError(path, sorted(unknown)[0],
                            f"unknown table (known: scenario, {', '.join(_TABLES)})")
    head = raw.get("scenario", {})
    if not isinstance(head, dict):
        raise ScenarioError(path, "scenario", "expected a table")
    # Checked on its own so that its keys are reported as ``scenario.<key>``.
    checked = from_table(_Head, head, file=path, section="scenario")
    table = {f.name: getattr(checked, f.name) for f in fields(_Head)}
    for name in _TABLES:
        if name in raw and name != "material":
            table[name] = raw[name]
    tissue = table.get("tissue")
    if isinstance(tissue, dict) and isinstance(tissue.get("surface_mesh"), str):
        table["tissue"] = {**tissue, "surface_mesh": [tissue["surface_mesh"]]}
    scenario = from_table(Scenario, table, file=path, section="")
    if "material" in raw:
        scenario = replace(scenario, material=_material(path, raw["material"]))
    if (isinstance(scenario.material, ContinuumMaterial)
            and scenario.simulation.integrator not in ("auto", "discrete")):
        raise ScenarioError(path, "simulation.integrator",
                            "MuJoCo runs flex continuum elasticity only with 'discrete'")
    curve = _resolve(path, scenario.aponeurosis.force_curve, "aponeurosis.force_curve")
    scans = tuple(_resolve(path, name, "tissue.surface_mesh")
                  for name in scenario.tissue.surface_mesh)
    knife, fixture = scenario.knife, scenario.fixture
    if knife.handle_mesh:
        knife = replace(knife, handle_mesh=_resolve(path, knife.handle_mesh, "knife.handle_mesh"))
    if fixture.clamp_mesh:
        fixture = replace(fixture, clamp_mesh=_resolve(path, fixture.clamp_mesh,
                                                       "fixture.clamp_mesh"))
    return replace(scenario, aponeurosis=replace(scenario.aponeurosis, force_curve=curve),
                   tissue=replace(scenario.tissue, surface_mesh=scans), knife=knife,
                   fixture=fixture, arms=_arms(path, scenario.arms))


def _arms(scenario_file: Path, arms: ArmsParams) -> ArmsParams:
    """``arms`` with each robot file found beside the scenario, and each arm read once so
    that a bad file, flange or limit is refused now, naming the scenario and the key."""
    for place in PLACES:
        choice = getattr(arms, place)
        if choice.file is not None:
            choice = replace(choice, file=_resolve(scenario_file, choice.file,
                                                   f"arms.{place}.file"))
            arms = replace(arms, **{place: choice})
        try:
            cell_arm(choice)
        except InputError as exc:
            raise ScenarioError(scenario_file, f"arms.{place}.{exc.field}",
                                f"{exc.message}" + (f" ({exc.file})" if exc.file else "")
                                ) from None
    return arms


def _material(scenario_file: Path, table: object) -> ContinuumMaterial | MassSpringMaterial:
    """The ``[material]`` table: ``file = "<material TOML>"`` alone, or the material inline.

    Errors come as :class:`ScenarioError` naming the file at fault (the scenario, or the
    material file it names) and the key.
    """
    try:
        return _read_material(scenario_file, table)
    except MaterialError as exc:
        raise ScenarioError(exc.file, exc.field, exc.message) from None


def _read_material(scenario_file: Path, table: object
                   ) -> ContinuumMaterial | MassSpringMaterial:
    if not isinstance(table, dict):
        raise ScenarioError(scenario_file, "material", "expected a table")
    if "file" in table:
        if len(table) > 1:
            extra = sorted(set(table) - {"file"})[0]
            raise ScenarioError(scenario_file, f"material.{extra}",
                                "give either file = ... or the material's keys, not both")
        if not isinstance(table["file"], str):
            raise ScenarioError(scenario_file, "material.file", "expected a path string")
        return load_material(_resolve(scenario_file, table["file"], "material.file"))
    return material_from_table(table, file=scenario_file, section="material")


def _resolve(scenario_file: Path, name: str, key: str) -> str:
    """A data file named in a scenario: absolute, relative to the scenario file, or one of the
    package's own (``assets/...``); it must exist."""
    candidates = [Path(name)] if Path(name).is_absolute() else [scenario_file.parent / name]
    if name.startswith(_ASSETS_PREFIX):
        candidates.append(asset_path(name.removeprefix(_ASSETS_PREFIX)))
    for candidate in candidates:
        if candidate.is_file():
            return str(candidate)
    raise ScenarioError(scenario_file, key, f"file not found: {name}")
