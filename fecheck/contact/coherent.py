"""Warm-started closest points on a triangle mesh: the last call's faces, searched locally.

Between two Newton iterations a slave vertex moves by a fraction of the broad-phase
margin, so its closest master face is the last one or a neighbour. `walk_point` walks
from each point's previous face to the closest face among the faces sharing a vertex
with it (its 1-ring, `face_rings`), repeating from the new face until the current face
is the closest of its own ring (a local minimum of the distance over the mesh), in at
most `max_steps` moves. `coherent_closest` visits only the ring faces that the last
calls' distances to them, less the point's travel since, do not prove farther than
the last face; `WalkState` holds what a point keeps between calls. Points
that start without a face or do not settle are flagged for a global (BVH) query. The
closest point on a triangle is Ericson's routine (Real-Time Collision Detection, 2005,
§5.1.5), compiled with numba.

A local minimum is the global one when the point is closer to the surface than the
surface's local feature size (as for slave vertices within the margin of a smooth
master). It is NOT certified: in a master thinner than twice the depth (a thin closed
layer), a point that crosses the layer's mid-surface between two broad-phase rebuilds
keeps the face on its first side. `fecheck.contact.mesh_master.MeshMaster` walks only
while a contact pair reuses its candidate set (points move < margin/2 since the last
tree query) and is tested against the tree (``tests/contact/test_contact_coherent.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit


@dataclass(frozen=True, eq=False)
class WalkState:
    """What a candidate set's points keep between two calls (master frame, mm); the
    arrays are updated in place by `fecheck.contact.kernels.walked_mesh_surface`.

    face : (n,) closest master face at the last call
    position : (n, 3) the points at the last call
    upper : (n,) an upper bound of the signed depth there (the exact depth if computed)
    travel : (n,) the path length of each point since the state started
    ring : (n, K) per face of the ring of `face`, a lower bound of the distance to it
        plus the point's travel when it was taken (-inf: unknown), see `coherent_closest`
    """

    face: np.ndarray
    position: np.ndarray
    upper: np.ndarray
    travel: np.ndarray
    ring: np.ndarray

    @classmethod
    def start(cls, face: np.ndarray, position: np.ndarray, depth: np.ndarray,
              ring_width: int) -> WalkState:
        """The state after a tree query: closest faces and exact depths, ring distances
        unknown (`ring_width`: the longest face ring of the master)."""
        n = len(face)
        return cls(np.ascontiguousarray(face, dtype=np.int64),
                   np.ascontiguousarray(position, dtype=float).copy(),
                   np.ascontiguousarray(depth, dtype=float).copy(), np.zeros(n),
                   np.full((n, ring_width), -np.inf))


def face_rings(faces: np.ndarray, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """The faces sharing a vertex with each face (its 1-ring, itself excluded) as CSR
    arrays (ptr (n_faces + 1,), index): the ring of face f is ``index[ptr[f]:ptr[f + 1]]``."""
    flat = faces.ravel()
    degree = np.bincount(flat, minlength=n_points)
    vertex_ptr = np.concatenate([[0], np.cumsum(degree)])
    around = np.argsort(flat, kind="stable") // 3              # faces of each vertex
    corner_face = np.repeat(np.arange(len(faces)), 3)
    owner = np.repeat(corner_face, degree[flat])               # (face, neighbour) pairs
    starts = np.repeat(vertex_ptr[flat] - np.cumsum(degree[flat]) + degree[flat],
                       degree[flat])
    neighbour = around[np.arange(len(owner)) + starts]
    key = np.unique(owner * len(faces) + neighbour)
    owner, neighbour = key // len(faces), key % len(faces)
    keep = owner != neighbour
    ptr = np.zeros(len(faces) + 1, dtype=np.int64)
    np.cumsum(np.bincount(owner[keep], minlength=len(faces)), out=ptr[1:])
    return ptr, neighbour[keep].astype(np.int64)


def edge_frames(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m, 9) per face: its first vertex a and edges b - a, c - a (mm), contiguous for
    `closest_on_triangle`."""
    tri = points[faces]
    return np.ascontiguousarray(np.concatenate(
        [tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]], axis=1))


@njit(cache=True, fastmath=False)
def closest_on_triangle(px, py, pz, E, f):
    """Closest point (qx, qy, qz) of face f (E: `edge_frames`, mm) to (px, py, pz) and
    its squared distance, mm² (Ericson's Voronoi-region routine)."""
    ax, ay, az = E[f, 0], E[f, 1], E[f, 2]
    abx, aby, abz = E[f, 3], E[f, 4], E[f, 5]
    acx, acy, acz = E[f, 6], E[f, 7], E[f, 8]
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:                                   # vertex a
        s, t = 0.0, 0.0
    else:
        bpx, bpy, bpz = apx - abx, apy - aby, apz - abz
        d3 = abx * bpx + aby * bpy + abz * bpz
        d4 = acx * bpx + acy * bpy + acz * bpz
        if d3 >= 0.0 and d4 <= d3:                                # vertex b
            s, t = 1.0, 0.0
        else:
            vc = d1 * d4 - d3 * d2
            if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:            # edge ab
                s, t = d1 / (d1 - d3), 0.0
            else:
                cpx, cpy, cpz = apx - acx, apy - acy, apz - acz
                d5 = abx * cpx + aby * cpy + abz * cpz
                d6 = acx * cpx + acy * cpy + acz * cpz
                if d6 >= 0.0 and d5 <= d6:                        # vertex c
                    s, t = 0.0, 1.0
                else:
                    vb = d5 * d2 - d1 * d6
                    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:     # edge ac
                        s, t = 0.0, d2 / (d2 - d6)
                    else:
                        va = d3 * d6 - d5 * d4
                        if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:   # edge bc
                            w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
                            s, t = 1.0 - w, w
                        else:                                     # interior
                            denom = 1.0 / (va + vb + vc)
                            s, t = vb * denom, vc * denom
    qx = ax + s * abx + t * acx
    qy = ay + s * aby + t * acy
    qz = az + s * abz + t * acz
    dx, dy, dz = px - qx, py - qy, pz - qz
    return qx, qy, qz, dx * dx + dy * dy + dz * dz


@njit(cache=True, fastmath=False)
def walk_point(px, py, pz, f, E, ptr, index, max_steps, ring, travel):
    """Walk from face f over face 1-rings to a face closest to (px, py, pz) among its own
    ring (E: `edge_frames`; ptr, index: `face_rings`). Returns (face, qx, qy, qz,
    squared distance mm², settled): not settled if still moving after `max_steps`.
    Once settled, ring (K,) holds the distances to the final face's ring plus `travel`
    (the bounds of `coherent_closest`)."""
    qx, qy, qz, best = closest_on_triangle(px, py, pz, E, f)
    for _ in range(max_steps):
        current = f
        start = ptr[current]
        for k in range(ptr[current + 1] - start):
            g = index[start + k]
            gx, gy, gz, d = closest_on_triangle(px, py, pz, E, g)
            ring[k] = np.sqrt(d) + travel
            if d < best or (d == best and g < f):          # ties: lowest index
                f, best, qx, qy, qz = g, d, gx, gy, gz
        if f == current:
            return f, qx, qy, qz, best, True
    return f, qx, qy, qz, best, False


@njit(cache=True, fastmath=False)
def coherent_closest(px, py, pz, f, ring, travel, E, ptr, index, max_steps):
    """`walk_point` from face f, checking only the ring faces that can be as close as f.

    ring (K,): per face of f's ring (in `face_rings` order), a lower bound of the
    point's distance to it (mm) plus the point's `travel` (mm, its path length so far)
    when the bound was taken; as a distance to a fixed face is 1-Lipschitz, ``ring[k] -
    travel`` still bounds it from below. Ring faces whose bound exceeds the distance to
    f cannot displace f and are not visited; the others are, and their bounds renewed.
    If one is closer, the walk runs and `ring` is renewed for the face it ends on.
    Returns (face, qx, qy, qz, squared distance mm², settled) as `walk_point`.
    """
    qx, qy, qz, best = closest_on_triangle(px, py, pz, E, f)
    dist = np.sqrt(best)
    start = ptr[f]
    for k in range(ptr[f + 1] - start):
        if ring[k] - travel <= dist:
            g = index[start + k]
            _, _, _, d = closest_on_triangle(px, py, pz, E, g)
            if d < best or (d == best and g < f):
                return walk_point(px, py, pz, f, E, ptr, index, max_steps, ring, travel)
            ring[k] = np.sqrt(d) + travel
    return f, qx, qy, qz, best, True


@njit(cache=True, fastmath=False)
def local_closest(E, ptr, index, points, start, max_steps):
    """Closest faces of `points` (n, 3) found by walking from `start` (n,) faces (-1:
    none) over face 1-rings (`walk_point`; E: `edge_frames`; ptr, index: `face_rings`).

    Returns (sq (n,) mm², face (n,), closest (n, 3) mm, settled (n,) bool); a point not
    settled (no start face, or still moving after `max_steps`) needs a global query.
    """
    n = points.shape[0]
    sq = np.empty(n)
    face = np.empty(n, dtype=np.int64)
    closest = np.empty((n, 3))
    settled = np.zeros(n, dtype=np.bool_)
    ring = np.empty(np.max(ptr[1:] - ptr[:-1]))     # scratch: walk_point's ring bounds
    for p in range(n):
        if start[p] < 0:
            face[p] = -1
            continue
        f, qx, qy, qz, best, ok = walk_point(points[p, 0], points[p, 1], points[p, 2],
                                             start[p], E, ptr, index, max_steps, ring, 0.0)
        sq[p], face[p], settled[p] = best, f, ok
        closest[p, 0], closest[p, 1], closest[p, 2] = qx, qy, qz
    return sq, face, closest, settled
