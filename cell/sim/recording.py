"""Headless Rerun recordings of an episode (``.rrd`` files for the Rerun viewer).

Layout: ``world/cell/<body>`` holds each robot and tool body (static shapes, a transform per
frame), ``world/tissue/<muscle>`` the muscle surfaces (static triangles, vertex positions per
frame), ``world/aponeurosis`` the bindings, ``world/knife_path/*`` the planned and executed
tip paths and the tip, ``world/perception/*`` what the camera gave (``look_<k>/*``: each
look's guideline, the seen opening and the next pass's tip path), ``world/camera`` the camera
with its RGB and depth images, ``forces/*`` and ``progress/*`` time series. Time is the
``sim_time`` timeline, in s.
"""

from __future__ import annotations

import atexit
import functools
import threading
import uuid
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Concatenate, ParamSpec, TypeVar

import mujoco
import numpy as np
import rerun as rr

from cell.errors import OutputError
from cell.outputs import AtomicFile
from cell.perception.pipeline import PerceivedPlan
from cell.profiling import timed_methods
from cell.robots.camera import CameraRig
from cell.sim.assembly import Scene
from cell.sim.liveview import LiveView

_RELEASE_COLOURS = {"knife": [255, 200, 0], "tearing": [255, 60, 200],
                    "force": [60, 200, 255]}
#: Frames held before they are sent as columns (one ``send_columns`` per entity instead of
#: one ``log`` per entity and frame: building each frame's archetypes cost more than the
#: data); the executed tip path is brought up to date as often. A live view gets each frame.
FRAMES_PER_BATCH = 64
#: Mean curvature (1/m) shown at full colour in the perception mesh.
_CURVATURE_SCALE_1_M = 30.0


def _xyzw(wxyz: np.ndarray) -> np.ndarray:
    """MuJoCo quaternions are (w, x, y, z); Rerun's are (x, y, z, w)."""
    return np.asarray(wxyz)[..., [1, 2, 3, 0]]


def _rgba8(rgba: np.ndarray) -> list[int]:
    return [round(255 * float(c)) for c in np.clip(rgba, 0, 1)]


def _entity(body_name: str) -> str:
    return "world/cell/" + body_name.replace("/", ".")


@dataclass(frozen=True)
class _Frame:
    """One frame of an episode held until its batch is sent (m, world frame)."""

    time_s: float
    translations: np.ndarray
    quaternions: np.ndarray
    tissue: dict[str, np.ndarray]
    bound: np.ndarray
    released: np.ndarray
    released_colours: np.ndarray
    tip: np.ndarray


def _partitioned(archetype: type, field: str, rows: list[np.ndarray]
                 ) -> rr.ComponentColumnList:
    """One ``field`` column of ``archetype`` holding ``rows`` (one array a frame)."""
    return archetype.columns(**{field: np.concatenate(rows)}).partition(
        [len(row) for row in rows])


_Args = ParamSpec("_Args")
_Result = TypeVar("_Result")


def _while_open(method: Callable[Concatenate[EpisodeRecorder, _Args], _Result]
                ) -> Callable[Concatenate[EpisodeRecorder, _Args], _Result]:
    """A recorder's method that sends to Rerun: one at a time, and refused once the recording
    is closed or aborted (a thread still logging at exit cannot hand Rerun new data then)."""
    @functools.wraps(method)
    def guarded(self: EpisodeRecorder, *args: _Args.args, **kwargs: _Args.kwargs) -> _Result:
        with self._lock:
            if self._finished:
                raise OutputError(self._file.path if self._file else None, None,
                                  "the recording is closed; nothing more can be logged to it")
            return method(self, *args, **kwargs)
    return guarded


@timed_methods("recording")
class EpisodeRecorder:
    """Writes one episode to a ``.rrd`` file, to a live viewer, or both; the file appears
    (atomically) at :meth:`close`.

    The recording streams to a temporary file beside it (:class:`~cell.outputs.AtomicFile`), so that
    a long episode does not grow in memory and a failed one (:meth:`abort`) leaves no file.

    Args:
        path: the ``.rrd`` file to write (None: none, only the live view).
        scene: the compiled cell.
        recording_id: fixed id, so that the same seed gives the same recording identity.
        view: the live view to stream to as well (:class:`~cell.sim.liveview.LiveView`).

    Example:
        >>> import tempfile
        >>> from cell.sim.assembly import build_scene
        >>> from cell.sim.scenario import Scenario
        >>> from cell.tissue.geometry import MuscleShape
        >>> scene = build_scene(Scenario(tissue=MuscleShape(cell_size_m=0.05)))
        >>> data = mujoco.MjData(scene.model)
        >>> mujoco.mj_forward(scene.model, data)
        >>> rec = EpisodeRecorder(Path(tempfile.mkdtemp()) / "episode.rrd", scene, "coarse-0")
        >>> rec.log_frame(data, knife_tip_m=np.zeros(3), scalars={"progress/released": 0.0})
        >>> rec.close().stat().st_size > 0
        True
    """

    def __init__(self, path: str | Path | None, scene: Scene, recording_id: str,
                 view: LiveView | None = None) -> None:
        self.scene = scene
        self.model = m = scene.model
        self.view = view
        self._lock = threading.RLock()
        self._finished = False
        rid = uuid.uuid5(uuid.NAMESPACE_URL, f"musclecell/{recording_id}")
        self.stream = rr.RecordingStream("musclecell", recording_id=rid)
        self._file = None if path is None else AtomicFile(Path(path))
        sinks = [] if self._file is None else [rr.FileSink(str(self._file.temporary))]
        self.stream.set_sinks(*sinks, *(view.sinks() if view is not None else []))
        tissue = set(scene.round_bodies.tolist()) | set(scene.shank_bodies.tolist())
        self._bodies = [b for b in range(1, self.model.nbody)
                        if b not in tissue and self.model.body_geomnum[b] > 0]
        self._tissue = {muscle: slice(m.flex_vertadr[f], m.flex_vertadr[f] + m.flex_vertnum[f])
                        for muscle in ("round", "shank")
                        for f in [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_FLEX, muscle)]}
        self._executed: list[np.ndarray] = []
        self._frames: list[_Frame] = []
        # A live view is sent each frame as it comes, so that it stays live.
        self._frames_per_batch = 1 if view is not None else FRAMES_PER_BATCH
        self._scalars: dict[str, tuple[list[float], list[float]]] = {}
        _OPEN_RECORDERS.add(self)
        self._log_static()

    def _geom_archetype(self, g: int) -> rr.AsComponents | None:
        m = self.model
        kind = m.geom_type[g]
        size = m.geom_size[g]
        pos = m.geom_pos[g]
        quat = _xyzw(m.geom_quat[g])
        colour = [_rgba8(m.geom_rgba[g])]
        if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
            axis = np.zeros(3)
            mujoco.mju_rotVecQuat(axis, np.array([0.0, 0.0, size[1]]), m.geom_quat[g])
            return rr.Capsules3D(lengths=[2 * size[1]], radii=[size[0]],
                                 translations=[pos - axis], quaternions=[quat], colors=colour)
        if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
            return rr.Cylinders3D(lengths=[2 * size[1]], radii=[size[0]], centers=[pos],
                                  quaternions=[quat], colors=colour, fill_mode="solid")
        if kind == mujoco.mjtGeom.mjGEOM_BOX:
            return rr.Boxes3D(half_sizes=[size], centers=[pos], quaternions=[quat],
                              colors=colour, fill_mode="solid")
        if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
            return rr.Ellipsoids3D(half_sizes=[[size[0]] * 3], centers=[pos], colors=colour,
                                   fill_mode="solid")
        return None

    def _log_static(self) -> None:
        m, s = self.model, self.stream
        s.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        for b in [0, *self._bodies]:
            name = "world/cell/static" if b == 0 else _entity(m.body(b).name)
            for g in range(m.body_geomadr[b], m.body_geomadr[b] + m.body_geomnum[b]):
                archetype = self._geom_archetype(g)
                if archetype is not None:
                    s.log(f"{name}/{m.geom(g).name or g}", archetype, static=True)
        for muscle in ("round", "shank"):
            mesh = getattr(self.scene.mesh, muscle)
            f = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_FLEX, muscle)
            s.log(f"world/tissue/{muscle}", rr.Mesh3D(
                vertex_positions=mesh.points, triangle_indices=mesh.boundary,
                albedo_factor=_rgba8(m.flex_rgba[f])), static=True)

    @_while_open
    def set_time(self, time_s: float) -> None:
        """Set the ``sim_time`` timeline for what is logged next."""
        self.stream.set_time("sim_time", duration=time_s)

    @_while_open
    def log_planned_path(self, path_m: np.ndarray) -> None:
        """The knife tip path the controller plans to follow."""
        self.stream.log("world/knife_path/planned",
                        rr.LineStrips3D([path_m], colors=[[0, 160, 255]], radii=0.0015),
                        static=True)

    @_while_open
    def log_perception(self, plan: PerceivedPlan) -> None:
        """What the camera gave, at the current time: the cloud, the surface mesh coloured by
        mean curvature (blue: valley, red: ridge), the guideline's nodes and its spline."""
        s = self.stream
        s.log("world/perception/cloud", rr.Points3D(plan.cloud_m, colors=[[200, 200, 200]],
                                                   radii=0.001))
        mean = np.clip(plan.curvature.mean_1_m / _CURVATURE_SCALE_1_M, -1.0, 1.0)
        colours = np.stack([np.clip(mean, 0, 1), np.zeros_like(mean), np.clip(-mean, 0, 1)], 1)
        s.log("world/perception/mesh", rr.Mesh3D(
            vertex_positions=plan.mesh.vertices_m, triangle_indices=plan.mesh.triangles,
            vertex_colors=(0.3 + 0.7 * colours) * 255))
        path = plan.guideline
        s.log("world/perception/guideline_nodes",
              rr.Points3D(plan.mesh.vertices_m[path.nodes], colors=[[0, 255, 120]], radii=0.003))
        s.log("world/perception/guideline",
              rr.LineStrips3D([path.points_m], colors=[[0, 255, 120]], radii=0.0015))

    @_while_open
    def log_look(self, index: int, guideline_m: np.ndarray, opening_m: np.ndarray,
                 tip_path_m: np.ndarray) -> None:
        """Look ``index`` of the camera (0 before the cut, k after pass k), at the current
        time, under ``world/perception/look_<index>``: its ``guideline`` (K, 3), the seen
        ``opening`` (the cloud's points along the cut, (N, 3)) and the ``tip_path`` (M, 3)
        the updated interface gives the next pass, m."""
        s, entity = self.stream, f"world/perception/look_{index}"
        s.log(f"{entity}/guideline", rr.LineStrips3D([guideline_m], colors=[[0, 255, 120]],
                                                     radii=0.0015))
        s.log(f"{entity}/opening", rr.Points3D(opening_m, colors=[[255, 220, 120]],
                                               radii=0.0012))
        s.log(f"{entity}/tip_path", rr.LineStrips3D([tip_path_m], colors=[[0, 160, 255]],
                                                    radii=0.001))

    @_while_open
    def log_frame(self, data: mujoco.MjData, knife_tip_m: np.ndarray,
                  scalars: dict[str, float]) -> None:
        """Body poses, muscle surfaces, bindings, the knife's tip and time series, at
        ``data.time``: held, then sent as columns every :data:`FRAMES_PER_BATCH` frames (each
        frame to a live view), with the executed tip path so far."""
        time_s = float(data.time)
        self.set_time(time_s)
        apo = self.scene.aponeurosis
        a, b = apo.endpoints(data)
        bound = apo.bound
        released = np.flatnonzero(~bound)
        tip = np.array(knife_tip_m, float)
        self._frames.append(_Frame(
            time_s, data.xpos[self._bodies].copy(), _xyzw(data.xquat[self._bodies]),
            {muscle: data.flexvert_xpos[rows].copy() for muscle, rows in self._tissue.items()},
            np.stack([a[bound], b[bound]], axis=1),
            0.5 * (a[released] + b[released]),
            np.array([_RELEASE_COLOURS[str(apo.released_by[i])] for i in released],
                     dtype=np.uint8).reshape(-1, 3),
            tip))
        self._executed.append(tip)
        for name, value in scalars.items():
            times, values = self._scalars.setdefault(name, ([], []))
            times.append(time_s)
            values.append(float(value))
        if len(self._frames) >= self._frames_per_batch:
            self._send_batch()

    def _send_batch(self) -> None:
        """Send the held frames and time series as columns on ``sim_time``, and the executed
        tip path so far at the current time."""
        frames, send = self._frames, self.stream.send_columns
        if frames:
            times = [rr.TimeColumn("sim_time", duration=[f.time_s for f in frames])]
            translations = np.stack([f.translations for f in frames], axis=1)
            quaternions = np.stack([f.quaternions for f in frames], axis=1)
            for i, b in enumerate(self._bodies):
                send(_entity(self.model.body(b).name), indexes=times,
                     columns=rr.Transform3D.columns(translation=translations[i],
                                                    quaternion=quaternions[i]))
            for muscle in self._tissue:
                send(f"world/tissue/{muscle}", indexes=times, columns=_partitioned(
                    rr.Mesh3D, "vertex_positions", [f.tissue[muscle] for f in frames]))
            every = len(frames)
            send("world/aponeurosis/bound", indexes=times, columns=[
                *_partitioned(rr.LineStrips3D, "strips", [f.bound for f in frames]),
                *rr.LineStrips3D.columns(colors=[[255, 255, 255]] * every,
                                         radii=[0.0008] * every)])
            send("world/aponeurosis/released", indexes=times, columns=[
                *_partitioned(rr.Points3D, "positions", [f.released for f in frames]),
                *_partitioned(rr.Points3D, "colors", [f.released_colours for f in frames]),
                *rr.Points3D.columns(radii=[0.0015] * every)])
            send("world/knife_path/tip", indexes=times, columns=rr.Points3D.columns(
                positions=np.stack([f.tip for f in frames]), colors=[[255, 80, 0]] * every,
                radii=[0.003] * every))
            self.stream.log("world/knife_path/executed", rr.LineStrips3D(
                [np.array(self._executed)], colors=[[255, 80, 0]], radii=0.001))
        for name, (times_s, values) in self._scalars.items():
            if times_s:
                column = rr.TimeColumn("sim_time", duration=times_s)
                send(name, indexes=[column], columns=rr.Scalars.columns(scalars=values))
        self._frames, self._scalars = [], {}

    @_while_open
    def log_camera(self, data: mujoco.MjData, rig: CameraRig) -> None:
        """The camera's pose, intrinsics, RGB and metric depth at ``data.time``."""
        s = self.stream
        self.set_time(float(data.time))
        position, rotation = rig.pose(data)
        s.log("world/camera", rr.Transform3D(translation=position, mat3x3=rotation))
        s.log("world/camera", rr.Pinhole(
            focal_length=rig.focal_px, width=rig.width_px, height=rig.height_px,
            camera_xyz=rr.ViewCoordinates.RUB))
        s.log("world/camera/rgb", rr.Image(rig.rgb(data)))
        s.log("world/camera/depth", rr.DepthImage(rig.depth(data), meter=1.0))

    @_while_open
    def close(self) -> Path | None:
        """Flush, hold a served live view (:meth:`LiveView.hold`), and move the recording into
        place (None: no file)."""
        self._send_batch()
        self.stream.flush()
        if self.view is not None:
            try:
                self.view.hold()
            except BaseException:
                self.abort()
                raise
        self._finish()
        return None if self._file is None else self._file.commit()

    def abort(self) -> None:
        """Drop the partial recording (the episode failed); a closed one stays."""
        with self._lock:
            if self._finished:
                return
            self._finish()
            if self._file is not None:
                self._file.discard()

    def _finish(self) -> None:
        # disconnect() sends what Rerun's threads still hold and frees it while Python can
        self.stream.disconnect()
        self._finished = True
        _OPEN_RECORDERS.discard(self)


#: Recordings neither closed nor aborted.
_OPEN_RECORDERS: weakref.WeakSet[EpisodeRecorder] = weakref.WeakSet()


@atexit.register  # registered after Rerun's own exit hook, so it runs before that one
def _abort_open_recordings() -> None:
    """At interpreter exit, abort the recordings still open. Rerun's threads free the data
    they hold, and NumPy-backed Arrow buffers need the GIL to be freed: one freed while the
    interpreter finalises ends the process (std::terminate). A recording never closed is an
    unfinished episode, so no file of it stays."""
    for recorder in list(_OPEN_RECORDERS):
        recorder.abort()


def open_recording(path: str | Path | None, view: LiveView | None, scene: Scene,
                   recording_id: str, cut_path_m: np.ndarray, perceived: PerceivedPlan | None,
                   first_pass_m: np.ndarray) -> EpisodeRecorder | None:
    """An episode's recording (to the file ``path``, the live ``view`` or both; None when
    neither is asked for), its planned tip path (``cut_path_m``) and, where the camera looked,
    its first look and the first pass's tip path (``first_pass_m``) logged."""
    if path is None and view is None:
        return None
    recorder = EpisodeRecorder(path, scene, recording_id, view)
    recorder.log_planned_path(cut_path_m)
    if perceived is not None:
        recorder.log_perception(perceived)
        recorder.log_look(0, perceived.guideline.points_m, perceived.cloud_m, first_pass_m)
    return recorder
