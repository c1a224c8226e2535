"""The cut guideline (paper Sec. 5.2): walk the valley between the two muscles from a start
point, node by node, and smooth the walk into a cut path for the blade.

From the start node P0, the walk collects the concave nodes (mean curvature below a threshold)
in the ball of radius r around the current node that no earlier ball covered, and steps to the
lowest of them, "the next node with lower height in the concave region". Height is measured
along the current node's surface normal, not the world's vertical: the valley rises towards the
middle of the meat and falls towards its tapered ends, and a world height would prefer a node
part-way up a wall behind to the valley's bottom ahead. When the ball holds no new concave
node, or the lowest lies more than ``max_rise_m`` above the current node (a step up a wall,
left over where the valley runs out at the meat's end), the walk looks farther
(``bridge_radius_m``) for a new concave node ahead, level with the current one (within
``max_rise_m`` up or down, so that it never drops onto the crease where the meat meets the
table): a short step leaves a ball mostly inside the ones before, and a normal tilted by the
sensor's noise lifts the few new nodes in it. It stops where there is none.

The paper starts at P0 on the surface's boundary, so its walk goes one way. Here the walk runs
twice from P0, the second time where the first one's balls did not reach; a start anywhere in
the valley gives the whole valley, end to end.

A smoothing spline through the nodes, sampled at an even spacing, gives the path: points, unit
tangents, and the surface normals (made orthogonal to the tangents) for the blade. It runs from
the end the second walk reached to the end the first one reached (from P0 when P0 is an end).

Example:
    >>> import numpy as np
    >>> from cell.perception.curvature import surface_curvature
    >>> from cell.perception.pointcloud import DepthView, depth_mesh
    >>> y_m = (np.arange(40)[:, None] - 19.5) * 0.005 + np.zeros((1, 80))  # groove along x
    >>> view = DepthView(0.5 + 0.02 * np.exp(-(y_m / 0.02) ** 2), 100.0,
    ...                  np.array([0.0, 0.0, 0.6]), np.eye(3))  # 2 cm deep, 0.5 m below
    >>> mesh = depth_mesh(view)
    >>> path = find_cut_path(mesh, surface_curvature(mesh, 0.015), np.array([-0.15, 0.0, 0.08]))
    >>> path.points_m[[0, -1], 0].round(2), path.length_m  # the groove, end to end
    (array([ 0.21, -0.21]), 0.41...)
    >>> round(float(np.linalg.norm(path.tangents[0])), 6)
    1.0
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import make_splprep
from scipy.spatial import cKDTree

from cell.errors import InputError, PerceptionError
from cell.perception.curvature import Curvature
from cell.perception.pointcloud import SurfaceMesh
from cell.polyline import arc_lengths, length, segment_lengths

# A sample's normal averages this many nearest vertices' normals: on the crease of the valley
# that takes in both walls.
_NORMAL_NEIGHBOURS = 8
# An end node's course is the line through this many walk nodes after it (3 to 5 cm).
_COURSE_NODES = 4
# The hook where the valley runs out is one or two nodes.
_MAX_DROPPED = 2
# An end node is off course where it lies this many times the walk's zigzag off: on a depth
# mesh binned 8 x 8 the zigzag reaches 10 mm, and a fixed bound ate the guideline's ends.
_ZIGZAG_SPREAD = 3.0


@dataclass(frozen=True)
class GuidelineParams:
    """How the valley is walked and the path sampled (SI units).

    The defaults suit the default camera's depth mesh binned 4 x 4 (nodes about 8 mm apart at
    0.6 m, about the paper's 1376 nodes) with curvature from a 15 mm ball. On finer meshes the
    sensor noise per node grows and the lowest node is more often a stray one; tested there,
    the walk stopped short in some runs.

    Attributes:
        search_radius_m: the paper's r: radius of the ball searched around each node; larger
            gives fewer, farther nodes. Make it wider than the concave band that the curvature
            ball spreads the valley's crease over (twice the curvature radius), so that a ball
            on the valley's bottom takes in the band's sides.
        concave_below_1_m: a node is concave (in the valley) where its mean curvature is below
            this, in 1/m: negative, since a depth mesh's normals face the camera and a valley
            then bends towards them.
        max_rise_m: the most a step may climb along the normal of the node it leaves. Along
            the valley's bottom the height changes only by the sensor's noise (about 1 mm at
            0.6 m); a step up a wall is a few millimetres.
        bridge_radius_m: how far ahead the walk looks when the ball around a node holds no
            new concave node low enough to step to (on shapes of the documented ranges the
            walk can otherwise stop early, with the valley's bottom going on, level, a few
            centimetres ahead).
        max_start_offset_m: a start point farther than this from every mesh vertex is off the
            meat.
        spacing_m: distance between the path's samples, along the path.
        smoothing_m: root-mean-square distance the spline may leave between itself and the
            walked nodes (it averages the node-to-node zigzag across the valley).
        max_end_offset_m: the walk's end nodes that lie farther than this across from the
            course of the nodes after them (plan view) are dropped: where the valley runs out
            at a tapered end, the last concave nodes can lie on the end's rounded edge,
            farther off the interface than the walk's zigzag across the valley ever takes a
            node.

    Raises:
        InputError: a non-positive radius, offset or spacing, or a negative rise or smoothing.

    Example:
        >>> GuidelineParams(search_radius_m=0.02).concave_below_1_m
        -7.0
    """

    search_radius_m: float = 0.03
    concave_below_1_m: float = -7.0
    max_rise_m: float = 0.0025
    bridge_radius_m: float = 0.06
    max_start_offset_m: float = 0.01
    spacing_m: float = 0.005
    smoothing_m: float = 0.002
    max_end_offset_m: float = 0.006

    def __post_init__(self) -> None:
        for name in ("search_radius_m", "bridge_radius_m", "max_start_offset_m", "spacing_m",
                     "max_end_offset_m"):
            if not getattr(self, name) > 0.0:
                raise InputError(None, name, f"must be > 0, got {getattr(self, name)}")
        for name in ("max_rise_m", "smoothing_m"):
            if not getattr(self, name) >= 0.0:
                raise InputError(None, name, f"must be >= 0, got {getattr(self, name)}")


@dataclass(frozen=True, eq=False)
class CutPath:
    """A cut guideline on the seen surface, sampled for the blade (world frame).

    Attributes:
        points_m: (K, 3) points along the path, ``spacing_m`` apart along it, m.
        tangents: (K, 3) unit tangents, in the direction of the walk.
        normals: (K, 3) unit surface normals (towards the camera), orthogonal to the tangents.
        nodes: (J,) mesh vertex indices P0, ..., Pn the walk picked, in order.

    Example:
        >>> import numpy as np
        >>> line = np.array([[0.0, 0.0, 0.0], [0.005, 0.0, 0.0], [0.01, 0.0, 0.0]])
        >>> along = np.tile([1.0, 0.0, 0.0], (3, 1))
        >>> CutPath(line, along, np.tile([0.0, 0.0, 1.0], (3, 1)), np.arange(3)).length_m
        0.01
    """

    points_m: np.ndarray
    tangents: np.ndarray
    normals: np.ndarray
    nodes: np.ndarray

    @property
    def length_m(self) -> float:
        """Length of the sampled path (the polyline through ``points_m``), m."""
        return length(self.points_m)


def _walk_valley(
    vertices: np.ndarray,
    tree: cKDTree,
    curvature: Curvature,
    start_m: np.ndarray,
    params: GuidelineParams,
) -> np.ndarray:
    """The node indices of the valley walk through the start node, end to end."""
    offset, start = tree.query(np.asarray(start_m, dtype=float).reshape(3))
    if offset > params.max_start_offset_m:
        raise PerceptionError(
            f"the start point is {offset:.3f} m from the nearest surface vertex (more than "
            f"{params.max_start_offset_m} m): it is off the meat"
        )
    concave = curvature.mean_1_m < params.concave_below_1_m
    ball = np.asarray(tree.query_ball_point(vertices[start], params.search_radius_m))
    if not concave[ball].any():
        raise PerceptionError(
            f"no concave node (mean curvature < {params.concave_below_1_m} 1/m) within "
            f"{params.search_radius_m} m of the start point: it is not in the valley"
        )
    covered = np.zeros(len(vertices), dtype=bool)

    def ball_of(node: int, radius_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The nodes within ``radius_m`` of ``node``, which of them are concave and not yet
        covered by a ball, and their height above it along its normal: the valley may rise or
        fall along its length (the meat tapers at its ends), which a world height would take
        for a wall."""
        ball = np.asarray(tree.query_ball_point(vertices[node], radius_m))
        fresh = concave[ball] & ~covered[ball]
        return ball, fresh, (vertices[ball] - vertices[node]) @ curvature.normals[node]

    def step(node: int, heading: np.ndarray | None) -> int | None:
        """The walk's next node after ``node``, reached along ``heading`` (None at the start),
        None at the valley's end."""
        covered[node] = True
        ball, fresh, rise = ball_of(node, params.search_radius_m)
        covered[ball] = True
        if fresh.any() and rise[fresh].min() <= params.max_rise_m:
            return int(ball[fresh][np.argmin(rise[fresh])])
        if heading is None:
            return None
        ball, fresh, rise = ball_of(node, params.bridge_radius_m)
        ahead = (vertices[ball] - vertices[node]) @ heading
        onward = fresh & (np.abs(rise) <= params.max_rise_m) & (ahead > 0.0)
        if not onward.any():
            return None
        chosen = np.flatnonzero(onward)[np.argmin(rise[onward])]
        # The stretch stepped over counts as walked: the walk must not turn back into it.
        covered[ball[ahead < ahead[chosen]]] = True
        return int(ball[chosen])

    def walk(node: int, heading: np.ndarray | None = None) -> list[int]:
        nodes = []
        while (following := step(node, heading)) is not None:
            heading = vertices[following] - vertices[node]
            nodes.append(node := following)
        return nodes

    forward = walk(int(start))
    if not forward:
        raise PerceptionError(
            f"every concave node within {params.search_radius_m} m of the start point lies more "
            f"than {params.max_rise_m} m above it: the start is not in the valley"
        )
    # A start inside the valley (rather than at its end) has valley on both sides, and the
    # walk above took one: walk again from the start, where the first walk's balls do not reach.
    covered[:] = False
    reached = tree.query_ball_point(vertices[forward], params.search_radius_m)
    covered[np.concatenate(reached)] = True
    # It leaves the start away from the first walk, so that it may bridge too: a start near
    # the meat's end whose first walk went to that end has no fresh node in its own ball
    # (without the bridge the guideline can end a centimetre or so from the start).
    backward = walk(int(start), vertices[start] - vertices[forward[0]])
    return np.array([*backward[::-1], int(start), *forward])


def _end_offset_m(end_m: np.ndarray, ahead_m: np.ndarray) -> float:
    """Plan-view distance (m) of the node ``end_m`` from the least-squares line through the
    nodes ``ahead_m`` (a few centimetres of the walk: its zigzag across the valley averages
    out over them)."""
    centre = ahead_m[:, :2].mean(axis=0)
    direction = np.linalg.svd(ahead_m[:, :2] - centre)[2][0]
    offset = end_m[:2] - centre
    return float(abs(offset[0] * direction[1] - offset[1] * direction[0]))


def _on_course(points_m: np.ndarray, max_offset_m: float) -> slice:
    """The walk's nodes (K, 3) without the end nodes (up to :data:`_MAX_DROPPED` at either
    end) that lie off the course of the :data:`_COURSE_NODES` nodes after them by more than
    ``max_offset_m`` and :data:`_ZIGZAG_SPREAD` times the root-mean-square of the same
    offset along the rest of the walk (its zigzag, which a coarse depth mesh widens)."""
    count = len(points_m)
    if count <= 2 * (_COURSE_NODES + _MAX_DROPPED):
        return slice(0, count)
    zigzag = [_end_offset_m(points_m[i], points_m[i + 1:i + 1 + _COURSE_NODES])
              for i in range(_MAX_DROPPED, count - _COURSE_NODES - _MAX_DROPPED)]
    limit_m = max(max_offset_m, _ZIGZAG_SPREAD * float(np.sqrt(np.mean(np.square(zigzag)))))

    def off_course(walk: np.ndarray) -> int:
        """How many of ``walk``'s first nodes to drop."""
        dropped = 0
        while (dropped < _MAX_DROPPED and _end_offset_m(
                walk[dropped], walk[dropped + 1:dropped + 1 + _COURSE_NODES]) > limit_m):
            dropped += 1
        return dropped

    return slice(off_course(points_m), count - off_course(points_m[::-1]))


def find_cut_path(
    mesh: SurfaceMesh,
    curvature: Curvature,
    start_m: np.ndarray,
    params: GuidelineParams | None = None,
) -> CutPath:
    """Walk the valley from ``start_m`` (m, world) and smooth it into a :class:`CutPath`.

    The walk's nodes are in :attr:`CutPath.nodes`. The spline is cubic (lower when the walk
    has fewer than four nodes), parametrised by chord length; the normals average the
    curvature normals of the vertices nearest each sample, which on the valley's crease is the
    bisector of its two walls.

    Raises:
        PerceptionError: fewer than two vertices, a start point off the meat, or no concave node
            within ``search_radius_m`` of it (the start is not in the valley).
        InputError: ``curvature`` does not belong to ``mesh``.
    """
    params = GuidelineParams() if params is None else params
    vertices = mesh.vertices_m
    if len(vertices) < 2:
        raise PerceptionError(f"the surface has {len(vertices)} vertices; a path needs two")
    if len(curvature.mean_1_m) != len(vertices):
        raise InputError(None, "curvature", "was computed on another mesh (vertex counts differ)")
    tree = cKDTree(vertices)
    nodes = _walk_valley(vertices, tree, curvature, start_m, params)
    nodes = nodes[_on_course(vertices[nodes], params.max_end_offset_m)]
    points = vertices[nodes]
    # A repeated position (a mesh may hold a point twice) would give a zero chord.
    keep = np.concatenate([[True], segment_lengths(points) > 0.0])
    points = points[keep]
    degree = min(3, len(points) - 1)
    spline, u = make_splprep(points.T, k=degree, s=len(points) * params.smoothing_m**2)
    dense_u = np.linspace(u[0], u[-1], 20 * len(points))
    dense = spline(dense_u).T
    arc = arc_lengths(dense)
    samples = max(2, round(arc[-1] / params.spacing_m) + 1)
    sample_u = np.interp(np.linspace(0.0, arc[-1], samples), arc, dense_u)
    path = spline(sample_u).T
    tangents = spline.derivative()(sample_u).T
    tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
    _, near = tree.query(path, k=min(_NORMAL_NEIGHBOURS, len(vertices)))
    normals = curvature.normals[near.reshape(len(path), -1)].sum(axis=1)
    normals -= np.einsum("ij,ij->i", normals, tangents)[:, None] * tangents
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return CutPath(path, tangents, normals, nodes)
