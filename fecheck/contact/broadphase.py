"""Broad phase: the slave faces within reach of the master, reused while the pose moves little.

A face is a candidate when one of its vertices has a master ``reach`` (a signed distance,
positive inside, 1-Lipschitz in the point) above ``-margin`` (the set may hold more, see
`CandidateCache`). Between two relative poses (slave in master frame) ``y = R p + t``
and ``y0 = R0 p + t0`` every slave vertex moves by at most
``|(R - R0) o + t - t0| + 2 sin(θ/2) ρ`` (``o`` the slave's vertex centroid, ``ρ`` its
radius about ``o``, θ the angle of ``R R0ᵀ``). While that bound stays below the reuse
limit, no face outside the set can have come into contact, so the set is reused: an
evaluation then touches only candidate vertices and faces. A face's contact is made
from its vertex depths (`fecheck.contact.kernels`): a face left out had every vertex at
reach <= -margin, so while the bound stays below the margin each is still outside and
the face out of contact. The limit is `REUSE_FRACTION` × margin for the sets asked of
the master's reach (mesh masters), ``reuse_fraction`` × margin (0.5) for the analytic
masters' half-spaces and balls. A rebuild asks a tree over the slave's vertices, built
once (`fecheck.contact.bvh`), for the master's region, so it too costs ∝ the faces near
the master, not the mesh.

The cache's state (tree tables, reference pose, counters and the set) lives in one
compiled object, `BroadPhaseState`, so that compiled code (`fecheck.laws.fused`) checks,
reuses or rebuilds the set within the same call as the contact kernel.

A rebuild that asks the master's ``reach`` (a mesh master: a closest-point query per
vertex) asks it only where the answer can have changed: each vertex keeps the last value
it was given and where it was then (master frame). A 1-Lipschitz reach is at most that
value plus the vertex's straight-line move since, so a vertex whose value plus move is at
or below ``-margin`` (less `BOUND_SLACK_MM`) is outside the set without a query, as a
query would find it; the set is the one a from-scratch rebuild gives. In a flexion sweep
the far vertices of the master's box (half of them, the costlier half of a closest-point
query) are then asked once every few degrees instead of at every rebuild.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numba import njit
from numba.core import types
from numba.experimental import structref

from fecheck.contact.bvh import BALL, HALF_SPACE, PointTree, gather_faces, owned_faces
from geometry.mesh import TriMesh


class Candidates(NamedTuple):
    """Slave faces near the master, with their per-face data in the slave frame (mm).

    faces : (m,) slave face indices
    vertices : (n,) slave vertex indices of `points`
    local_faces : (m, 3) vertex indices into `points`
    points : (n, 3) vertex coordinates
    normals : (m, 3) unit outward face normals
    areas : (m,) face areas, mm²
    """

    faces: np.ndarray
    vertices: np.ndarray
    local_faces: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    areas: np.ndarray


@njit(cache=True, fastmath=False)
def motion_bound(R: np.ndarray, t: np.ndarray, R0: np.ndarray, t0: np.ndarray,
                 centroid: np.ndarray, radius: float) -> float:
    """Largest displacement of any slave vertex between two relative poses, mm (an upper
    bound): ``|(R - R0) o + t - t0| + 2 sin(θ/2) ρ``."""
    trace = 0.0                                                  # tr(R R0ᵀ)
    shift2 = 0.0
    for i in range(3):
        s = t[i] - t0[i]
        for j in range(3):
            trace += R[i, j] * R0[i, j]
            s += (R[i, j] - R0[i, j]) * centroid[j]
        shift2 += s * s
    cos_theta = min(max((trace - 1.0) * 0.5, -1.0), 1.0)
    chord = math.sqrt(2.0 * (1.0 - cos_theta))                   # 2 sin(θ/2)
    return math.sqrt(shift2) + chord * radius


@njit(cache=True, fastmath=False)
def relative_pose(Rs: np.ndarray, ts: np.ndarray, Rm: np.ndarray, tm: np.ndarray):
    """The slave pose in the master frame, ``y = R p + t``: R = Rmᵀ Rs, t = Rmᵀ (ts - tm)
    (rotations (3, 3), translations (3,) mm)."""
    R = np.empty((3, 3))
    t = np.empty(3)
    for i in range(3):
        t[i] = (Rm[0, i] * (ts[0] - tm[0]) + Rm[1, i] * (ts[1] - tm[1])
                + Rm[2, i] * (ts[2] - tm[2]))
        for j in range(3):
            R[i, j] = Rm[0, i] * Rs[0, j] + Rm[1, i] * Rs[1, j] + Rm[2, i] * Rs[2, j]
    return R, t


@njit(cache=True, fastmath=False)
def pose_status(R: np.ndarray, t: np.ndarray) -> int:
    """0 for a valid pose; 1 if the translation (3,) is not finite; 2 if R (3, 3) is not a
    rotation: orthonormal columns within 1e-6 and det +1 (NaN fails every comparison)."""
    if not (math.isfinite(t[0]) and math.isfinite(t[1]) and math.isfinite(t[2])):
        return 1
    tol = 1e-6
    for i in range(3):
        for j in range(i, 3):
            dot = R[0, i] * R[0, j] + R[1, i] * R[1, j] + R[2, i] * R[2, j]
            if not abs(dot - (1.0 if i == j else 0.0)) <= tol:
                return 2
    det = (R[0, 0] * (R[1, 1] * R[2, 2] - R[1, 2] * R[2, 1])
           - R[0, 1] * (R[1, 0] * R[2, 2] - R[1, 2] * R[2, 0])
           + R[0, 2] * (R[1, 0] * R[2, 1] - R[1, 1] * R[2, 0]))
    return 0 if det > 0.0 else 2


@njit(cache=True, fastmath=False)
def checked_relative_pose(Rs: np.ndarray, ts: np.ndarray, Rm: np.ndarray, tm: np.ndarray):
    """`relative_pose` and the `pose_status` of the slave and the master pose, in one
    compiled call (the contact query's per-call overhead)."""
    R, t = relative_pose(Rs, ts, Rm, tm)
    return R, t, pose_status(Rs, ts), pose_status(Rm, tm)


_STATE_FIELDS = ("points", "order", "lo", "hi", "child", "span", "owner_ptr", "extent",
                 "node_extent", "out",
                 "face_order", "corners", "normals", "areas", "vertex_index", "region_kind",
                 "region_params", "centroid", "radius", "limit", "ref_R", "ref_t", "counts",
                 "cand_faces", "cand_vertices", "cand_local", "cand_points", "cand_normals",
                 "cand_areas", "cand_ranks")


@structref.register
class BroadPhaseType(types.StructRef):
    """numba type of a `BroadPhaseState`."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


class BroadPhaseState(structref.StructRefProxy):
    """A broad phase's compiled state, one object so that compiled code takes it in one
    argument: the slave's tree and tables (`fecheck.contact.bvh.PointTree`), the master's
    region (kind -1: none that the tree can answer alone), the motion bound's centroid,
    radius and reuse limit (mm), the reference pose and counters of the current candidate
    set (``counts``: has a set, rebuilds, reuses, its arrays gathered), and that set
    (`Candidates`' arrays, and for a region query the ranks of its faces in the tree's
    face tables, `fecheck.contact.bvh.owner_tables`)."""


structref.define_proxy(BroadPhaseState, BroadPhaseType, _STATE_FIELDS)


@njit(cache=True)
def _new_state(points, order, lo, hi, child, span, owner_ptr, extent, node_extent, out,
               face_order, corners, normals, areas, vertex_index, region_kind, region_params,
               centroid, radius, limit, ref_R, ref_t, counts):
    return BroadPhaseState(points, order, lo, hi, child, span, owner_ptr, extent,
                           node_extent, out, face_order, corners, normals, areas,
                           vertex_index, region_kind, region_params, centroid, radius, limit,
                           ref_R, ref_t, counts,
                           np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64),
                           np.zeros((0, 3), dtype=np.int64), np.zeros((0, 3)),
                           np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=np.int64))


@njit(cache=True, fastmath=False)
def reused_set(state, R: np.ndarray, t: np.ndarray) -> int:
    """The rebuild count of the current set if it can serve the relative pose (R, t)
    (counted as a reuse), else -1."""
    counts = state.counts
    if counts[0] and motion_bound(R, t, state.ref_R, state.ref_t, state.centroid,
                                  state.radius) <= state.limit:
        counts[2] += 1
        return counts[1]
    return -1


@njit(cache=True, fastmath=False)
def store_set(state, R: np.ndarray, t: np.ndarray, faces: np.ndarray, vertices: np.ndarray,
              local: np.ndarray, points: np.ndarray, normals: np.ndarray,
              areas: np.ndarray) -> int:
    """Make (faces, …, areas) the current set, built at the relative pose (R, t); the new
    rebuild count."""
    hold_data(state, faces, vertices, local, points, normals, areas)
    state.cand_ranks = np.zeros(0, dtype=np.int64)
    return rebuilt(state, R, t, 1)


@njit(cache=True, fastmath=False)
def hold_data(state, faces: np.ndarray, vertices: np.ndarray, local: np.ndarray,
              points: np.ndarray, normals: np.ndarray, areas: np.ndarray) -> None:
    """Make (faces, …, areas) the current set's per-face `Candidates` arrays."""
    state.cand_faces = faces
    state.cand_vertices = vertices
    state.cand_local = local
    state.cand_points = points
    state.cand_normals = normals
    state.cand_areas = areas


@njit(cache=True, fastmath=False)
def rebuilt(state, R: np.ndarray, t: np.ndarray, has_data: int) -> int:
    """Record a rebuild of the current set at the relative pose (R, t), its per-face data
    gathered (`has_data` 1) or not yet (0); the new rebuild count."""
    state.ref_R[:, :] = R
    state.ref_t[:] = t
    counts = state.counts
    counts[0] = 1
    counts[1] += 1
    counts[3] = has_data
    return counts[1]


@njit(cache=True, fastmath=False)
def region_ranks(state, R: np.ndarray, t: np.ndarray) -> int:
    """Make the current set serve the relative pose (R, t) for a master whose region is
    exactly reach > -margin (a half-space or a ball): reused, or rebuilt by the tree's
    region query (`fecheck.contact.bvh.owned_faces`) as the ranks of its faces only,
    ``state.cand_ranks`` (their data gathered when asked for, `gathered`); the rebuild
    count."""
    n = reused_set(state, R, t)
    if n >= 0:
        return n
    m = owned_faces(state.region_kind, state.region_params, R, t, state.points, state.order,
                    state.lo, state.hi, state.child, state.span, state.owner_ptr,
                    state.extent, state.node_extent, state.out)
    state.cand_ranks = state.out[:m].copy()
    return rebuilt(state, R, t, 0)


@njit(cache=True, fastmath=False)
def gathered(state) -> None:
    """Gather the per-face data of a set of ranks (`region_ranks`) into the state's
    `Candidates` arrays, unless they are already the current set's."""
    if state.counts[3]:
        return
    faces, vertices, local, points, normals, areas = gather_faces(
        state.cand_ranks, state.face_order, state.corners, state.normals, state.areas,
        state.points, state.vertex_index)
    hold_data(state, faces, vertices, local, points, normals, areas)
    state.counts[3] = 1


@njit(cache=True, fastmath=False)
def region_set(state, R: np.ndarray, t: np.ndarray) -> int:
    """`region_ranks`, with the set's `Candidates` arrays gathered; the rebuild count."""
    n = region_ranks(state, R, t)
    gathered(state)
    return n


@njit(cache=True)
def current_set(state):
    """The current set's arrays, in `Candidates`' order."""
    gathered(state)
    return (state.cand_faces, state.cand_vertices, state.cand_local, state.cand_points,
            state.cand_normals, state.cand_areas)


REMEMBERED_BUILDS = 4
"""How many rebuilt sets a `CandidateCache` keeps by their pose."""
RECENT_SETS = 4
"""How many sets built since the last `CandidateCache.reset` a cache keeps with their
poses: a pose back within the reuse limit of one of them (a Newton line search's shorter
step after a longer trial) takes that set again instead of a rebuild."""
BOUND_SLACK_MM = 1e-9
"""A vertex is left out of a rebuild without asking the reach only if its bound lies this
far below -margin (mm): round-off of the bound cannot then decide a vertex that a query
would keep."""


REUSE_FRACTION = 0.9
"""The reuse limit of a set found by asking the master's reach (a mesh master, or a box),
as a fraction of the margin (module docstring); the rest, 0.2 mm of a 2 mm margin, is
slack. The scanned knee's population samples solve about 1.2 times as fast as at 0.5
(`validation/population_study.py`), to the same contact."""


class CandidateCache:
    """Candidate faces of one slave against one master, rebuilt only when needed.

    Parameters
    ----------
    slave : the slave mesh (slave frame, mm)
    reach : function of (n, 3) master-frame points -> (n,) signed distance, mm
    margin_mm : reach kept around the master, mm
    reuse_fraction : with a half-space or a ball, reuse the set while the motion bound is
        below this × margin; otherwise `REUSE_FRACTION` × margin
    region : optional (kind, params) of `fecheck.contact.bvh`, a master-frame region
        holding every point with reach > -margin (a half-space or a ball: exactly those;
        a box: `reach` then decides). A rebuild asks a tree built once
        (`fecheck.contact.bvh.PointTree`), at a cost ∝ the faces near the master;
        without a region every vertex is tested.
    lipschitz_reach : the reach is 1-Lipschitz in the point (a signed distance), so a
        rebuild asks it only for the vertices whose last value plus their move since can
        exceed -margin (module docstring); every value it gives at or below -margin must
        then be an upper bound of the signed distance

    Notes
    -----
    With a box (or no region) the set is the faces with a vertex whose reach > -margin.
    With a half-space or a ball it also holds some faces near those: the faces owned
    by a vertex whose reach > -(margin + its extent) (`fecheck.contact.bvh.owned_faces`),
    which the tree finds as whole ranges of faces, without testing any face's corners.

    The state lives in a `BroadPhaseState` (``state``), which compiled callers update
    themselves (`region_set`); `get` reads what they left.
    """

    def __init__(self, slave: TriMesh, reach: Callable[[np.ndarray], np.ndarray],
                 margin_mm: float, reuse_fraction: float = 0.5,
                 region: tuple[int, np.ndarray] | None = None,
                 lipschitz_reach: bool = False) -> None:
        self.slave = slave
        self.reach = reach
        self.margin_mm = float(margin_mm)
        # per vertex: the last reach asked (NaN: never) and the master-frame point it was
        # asked at, the bounds of a rebuild's `_asked` (lipschitz_reach only)
        self._bounded = bool(lipschitz_reach)
        self._known_reach = np.full(slave.n_points, np.nan)
        self._known_at = np.zeros((slave.n_points, 3))
        self.n_reach_points = 0
        """Vertices whose reach the rebuilds asked so far."""
        # built once per body, in the model's build
        self.tree = PointTree(slave.points, slave.faces, slave.face_normals, slave.face_areas)
        eye, zero = np.eye(3), np.zeros(3)
        checked_relative_pose(eye, zero, eye, zero)
        centroid = slave.points.mean(axis=0)
        radius = float(np.linalg.norm(slave.points - centroid, axis=1).max())
        self.region = region
        kind, params = region if region is not None else (-1, np.zeros(0))
        self.exact = kind in (HALF_SPACE, BALL)
        limit = (float(reuse_fraction) if self.exact else REUSE_FRACTION) * self.margin_mm
        self._counts = np.zeros(4, dtype=np.int64)
        tree = self.tree
        self.state = _new_state(
            *tree.owned_tables, kind, np.ascontiguousarray(params, dtype=float), centroid,
            radius, limit, np.eye(3), np.zeros(3),
            self._counts)
        self._seen = 0
        self._current: Candidates | None = None
        self._builds: dict[bytes, tuple] = {}
        # the sets built since the last reset: (reference R, t, the set's arrays)
        self._recent: list[tuple[np.ndarray, np.ndarray, tuple]] = []
        self._bound = (centroid, radius, limit)
        self._restored = 0
        self._load_kernels()

    def _load_kernels(self) -> None:
        """Run the compiled state updates once (load them now, in the model's build, not
        in a solve), then start from an empty state."""
        eye, zero = np.eye(3), np.zeros(3)
        if self.exact:
            region_set(self.state, eye, zero)
        else:
            store_set(self.state, eye, zero, *current_set(self.state))
        reused_set(self.state, eye, zero)
        self._counts[:] = 0

    @property
    def reuse_limit_mm(self) -> float:
        """How far the slave may move (the motion bound, mm) before the set is rebuilt."""
        return self._bound[2]

    @property
    def n_rebuilds(self) -> int:
        """Candidate sets built so far (not counting recent sets taken again)."""
        return int(self._counts[1]) - self._restored

    @property
    def n_reuses(self) -> int:
        """Calls that reused the current set."""
        return int(self._counts[2])

    def get(self, R: np.ndarray, t: np.ndarray) -> Candidates:
        """Candidates for the relative pose (slave → master frame) ``y = R p + t``."""
        if self.exact:
            n = region_set(self.state, R, t)
        else:
            n = reused_set(self.state, R, t)
            if n < 0:
                n = self._restore(R, t)
            if n < 0:
                built = self._remembered(R, t)
                n = store_set(self.state, R, t, *built)
                self._recent.append((np.array(R, dtype=float), np.array(t, dtype=float),
                                     built))
                del self._recent[:-RECENT_SETS]
        return self._read(n)

    def _restore(self, R: np.ndarray, t: np.ndarray) -> int:
        """Make the latest recent set (`RECENT_SETS`) that can serve the relative pose
        (R, t) the current one, at its own reference pose (counted as a reuse); its count,
        or -1 if none can. Exact as a reuse is: no face outside a set can touch while
        the motion bound from the set's pose stays below the limit."""
        centroid, radius, limit = self._bound
        for R0, t0, built in reversed(self._recent):
            if motion_bound(R, t, R0, t0, centroid, radius) <= limit:
                n = store_set(self.state, R0, t0, *built)
                self._restored += 1
                self._counts[2] += 1
                return n
        return -1

    def _remembered(self, R: np.ndarray, t: np.ndarray):
        """`_build` at (R, t), or the faces of an earlier build at exactly that pose (a
        population's samples each start from one baseline pose): the set is a function
        of the pose alone. The last `REMEMBERED_BUILDS` poses are kept."""
        key = np.asarray(R, dtype=float).tobytes() + np.asarray(t, dtype=float).tobytes()
        if key not in self._builds:
            if len(self._builds) >= REMEMBERED_BUILDS:
                del self._builds[next(iter(self._builds))]
            self._builds[key] = self._build(R, t)
        return self._builds[key]

    def _read(self, n: int) -> Candidates:
        """The current set as `Candidates`, read from the state when rebuild `n` is new."""
        if n != self._seen:
            self._current = Candidates(*current_set(self.state))
            self._seen = n
        return self._current

    def _build(self, R: np.ndarray, t: np.ndarray):
        """The faces with a vertex whose reach > -margin at the relative pose (R, t), when
        the region alone cannot tell (a box, or no region)."""
        if self.region is None:
            y = self.slave.points @ R.T + t
            return self.tree.faces_of(np.flatnonzero(
                self._asked(np.arange(self.slave.n_points), y) > -self.margin_mm))
        kind, params = self.region
        near = self.tree.near(kind, params, R, t)
        if near.size:
            near = near[self._asked(near, self.slave.points[near] @ R.T + t)
                        > -self.margin_mm]
        return self.tree.faces_of(near)

    def _asked(self, vertices: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The reach of `vertices` at their master-frame points `y` (n, 3), mm; with a
        1-Lipschitz reach, -inf for those whose bound (last value plus straight-line move
        since) proves them at or below -margin, the others asked (and their bounds
        renewed)."""
        if not self._bounded:
            self.n_reach_points += len(y)
            return self.reach(y)
        bound = self._known_reach[vertices] + np.linalg.norm(y - self._known_at[vertices],
                                                             axis=1)
        ask = np.flatnonzero(~(bound <= -self.margin_mm - BOUND_SLACK_MM))   # NaN: ask
        out = np.full(len(y), -np.inf)
        if ask.size:
            out[ask] = self.reach(y[ask])
            self._known_reach[vertices[ask]] = out[ask]
            self._known_at[vertices[ask]] = y[ask]
        self.n_reach_points += ask.size
        return out

    @property
    def current(self) -> Candidates | None:
        """The candidate set of the last call (None before the first, or after `reset`)."""
        return self._read(int(self._counts[1])) if self._counts[0] else None

    def reset(self) -> None:
        """Forget the cached set and the recent ones (the next call rebuilds it)."""
        self._counts[0] = 0
        self._recent = []
