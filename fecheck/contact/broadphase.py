"""Broad phase: the slave faces within reach of the master, reused while the pose moves little.

A face is a candidate when one of its vertices has a master ``reach`` (a signed distance,
positive inside, 1-Lipschitz in the point) above ``-margin``. Between two relative poses
(slave in master frame) ``y = R p + t`` and ``y0 = R0 p + t0`` every slave vertex moves by
at most ``|(R - R0) o + t - t0| + 2 sin(θ/2) ρ`` (``o`` the slave's vertex centroid,
``ρ`` its radius about ``o``, θ the angle of ``R R0ᵀ``). While that bound stays below
``reuse_fraction · margin``, no face outside the set can have come into contact, so the
set is reused: an evaluation then touches only candidate vertices and faces. A rebuild
asks a tree over the slave's vertices, built once (`fecheck.contact.bvh`), for those in
the master's region, so it too costs ∝ the faces near the master, not the mesh.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numba import njit

from fecheck.contact.bvh import BOX, PointTree
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


class CandidateCache:
    """Candidate faces of one slave against one master, rebuilt only when needed.

    Parameters
    ----------
    slave : the slave mesh (slave frame, mm)
    reach : function of (n, 3) master-frame points -> (n,) signed distance, mm
    margin_mm : reach kept around the master, mm
    reuse_fraction : reuse the set while the motion bound is below this × margin
    region : optional (kind, params) of `fecheck.contact.bvh`, a master-frame region
        holding every point with reach > -margin (a half-space or a ball: exactly those;
        a box: `reach` then decides). A rebuild finds the slave vertices in it through a
        tree built once (`fecheck.contact.bvh.PointTree`), at a cost ∝ the vertices near
        the master; without a region every vertex is tested.
    """

    def __init__(self, slave: TriMesh, reach: Callable[[np.ndarray], np.ndarray],
                 margin_mm: float, reuse_fraction: float = 0.5,
                 region: tuple[int, np.ndarray] | None = None) -> None:
        self.slave = slave
        self.reach = reach
        self.margin_mm = float(margin_mm)
        self.reuse_fraction = float(reuse_fraction)
        self.region = region
        # built once per body, in the model's build
        self.tree = PointTree(slave.points, slave.faces, slave.face_normals, slave.face_areas)
        eye, zero = np.eye(3), np.zeros(3)
        motion_bound(eye, zero, eye, zero, zero, 1.0)
        checked_relative_pose(eye, zero, eye, zero)
        self.centroid = slave.points.mean(axis=0)
        self.radius = float(np.linalg.norm(slave.points - self.centroid, axis=1).max())
        self.n_rebuilds = 0
        self.n_reuses = 0
        self._ref: tuple[np.ndarray, np.ndarray] | None = None
        self._current: Candidates | None = None

    def get(self, R: np.ndarray, t: np.ndarray) -> Candidates:
        """Candidates for the relative pose (slave → master frame) ``y = R p + t``."""
        if self._ref is not None:
            bound = motion_bound(R, t, *self._ref, self.centroid, self.radius)
            if bound <= self.reuse_fraction * self.margin_mm:
                self.n_reuses += 1
                return self._current
        self._current = self._build(R, t)
        self._ref = (R.copy(), t.copy())
        self.n_rebuilds += 1
        return self._current

    def _build(self, R: np.ndarray, t: np.ndarray) -> Candidates:
        """The faces with a vertex whose reach > -margin at the relative pose (R, t)."""
        if self.region is None:
            y = self.slave.points @ R.T + t
            return Candidates(*self.tree.faces_of(np.flatnonzero(self.reach(y) > -self.margin_mm)))
        kind, params = self.region
        if kind != BOX:                       # the region is exactly reach > -margin
            return Candidates(*self.tree.faces_in(kind, params, R, t))
        near = self.tree.near(kind, params, R, t)
        if near.size:
            near = near[self.reach(self.slave.points[near] @ R.T + t) > -self.margin_mm]
        return Candidates(*self.tree.faces_of(near))

    @property
    def current(self) -> Candidates | None:
        """The candidate set of the last call (None before the first)."""
        return self._current

    def reset(self) -> None:
        """Forget the cached set (the next call rebuilds it)."""
        self._ref = None
        self._current = None
