"""Generalised winding numbers of a triangle mesh, exact and hierarchical (mm).

The winding number of a mesh at a point q is w(q) = Σ_f Ω_f(q) / 4π, Ω_f the signed solid
angle of face f seen from q (Van Oosterom & Strackee 1983, as ``igl.winding_number``
computes it). For a closed mesh with outward normals it is 1 inside and 0 outside, and it
stays an integer where the mesh has self-intersections (inside: w > 1/2).

Summing every face costs O(faces) per point (24 µs at 3,124 faces). `WindingTree` sums
them hierarchically, and exactly (Jacobson, Kavan & Sorkine-Hornung 2013, §3.3): a
tree of boxes over the faces (median splits of the face centroids, `fecheck.contact.bvh`,
each box grown to hold its faces' corners); for the faces S of a node, the fan of
triangles (c, b, a) from the box centre c over the boundary half-edges (a, b) of S (those
not cancelled by an opposite half-edge of S) closes S into a cycle inside the box, whose
winding number is 0 at any q outside the box. So there w_S(q) = Σ_(a,b) Ω(c, a, b)(q) / 4π
over ~√|S| boundary edges instead of |S| faces, for any mesh. A query descends only into
the boxes that hold q; at a leaf it sums the faces. The sums differ from the face-by-face
ones by rounding only (≤ 1e-12 here, `tests/contact/test_winding.py`); the inside test w > 1/2
is the same wherever |w - 1/2| exceeds that.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from fecheck.contact.bvh import build_tree

FOUR_PI = 4.0 * math.pi
GRID_PAD_MM = 3.0
"""`SideGrid` covers the mesh's box grown by this (a broad phase's margin, 2 mm, and more)."""
GRID_NODES = 100_000
"""`SideGrid` widens its spacing to keep to about this many nodes (measured, once per mesh
and then read from the cache: 0.3 s for a meniscus's 29,155 nodes at 1 mm, 3.9 s for the
whole master of a 5,120-face sphere of radius 31.8 mm at 110,592 nodes 1.5 mm apart)."""


@njit(cache=True, fastmath=False, inline="always")
def _solid_angle(qx, qy, qz, a, b, c) -> float:
    """Signed solid angle (sr) of the triangle (a, b, c) seen from q (Van Oosterom &
    Strackee 1983): 2 atan2(A·(B×C), |A||B||C| + (A·B)|C| + (B·C)|A| + (C·A)|B|)."""
    ax, ay, az = a[0] - qx, a[1] - qy, a[2] - qz
    bx, by, bz = b[0] - qx, b[1] - qy, b[2] - qz
    cx, cy, cz = c[0] - qx, c[1] - qy, c[2] - qz
    la = math.sqrt(ax * ax + ay * ay + az * az)
    lb = math.sqrt(bx * bx + by * by + bz * bz)
    lc = math.sqrt(cx * cx + cy * cy + cz * cz)
    det = ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
    den = (la * lb * lc + (ax * bx + ay * by + az * bz) * lc
           + (bx * cx + by * cy + bz * cz) * la + (cx * ax + cy * ay + cz * az) * lb)
    return 2.0 * math.atan2(det, den)


@njit(cache=True)
def face_winding(points: np.ndarray, faces: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """(n,) winding numbers at `queries` (n, 3), summed face by face (the reference)."""
    out = np.zeros(queries.shape[0])
    for i in range(queries.shape[0]):
        s = 0.0
        for f in range(faces.shape[0]):
            s += _solid_angle(queries[i, 0], queries[i, 1], queries[i, 2],
                              points[faces[f, 0]], points[faces[f, 1]], points[faces[f, 2]])
        out[i] = s / FOUR_PI
    return out


@njit(cache=True)
def _boundary(faces: np.ndarray, ids: np.ndarray, n_points: int) -> np.ndarray:
    """(k, 2) boundary half-edges (a, b) of the faces `ids`: each undirected edge with
    the net count of its half-edges a→b less b→a, repeated |count| times, oriented by
    the sign."""
    m = 3 * ids.size
    key = np.empty(m, dtype=np.int64)
    sign = np.empty(m, dtype=np.int64)
    for i in range(ids.size):
        for k in range(3):
            a, b = faces[ids[i], k], faces[ids[i], (k + 1) % 3]
            key[3 * i + k] = min(a, b) * n_points + max(a, b)
            sign[3 * i + k] = 1 if a < b else -1
    order = np.argsort(key)
    out = np.empty((m, 2), dtype=np.int64)
    n, i = 0, 0
    while i < m:
        j, net = i, 0
        while j < m and key[order[j]] == key[order[i]]:
            net += sign[order[j]]
            j += 1
        lo, hi = key[order[i]] // n_points, key[order[i]] % n_points
        for _ in range(abs(net)):
            out[n, 0], out[n, 1] = (lo, hi) if net > 0 else (hi, lo)
            n += 1
        i = j
    return out[:n]


@njit(cache=True)
def build_tables(points: np.ndarray, faces: np.ndarray):
    """The tree of `WindingTree`: face order (m,) grouped by node; per node lo, hi (3,)
    of its faces' corners, children (2,) (-1 at a leaf), first and count of its faces in
    the order, and its fan (centre (3,), the box's, and boundary half-edges
    ``edges[ptr[i]:ptr[i+1]]``; ptr[i+1] - ptr[i] > count: the fan costs more than the
    faces and is not used)."""
    centroids = np.empty((faces.shape[0], 3))
    for f in range(faces.shape[0]):
        for k in range(3):
            centroids[f, k] = (points[faces[f, 0], k] + points[faces[f, 1], k]
                               + points[faces[f, 2], k]) / 3.0
    order, lo, hi, child, span = build_tree(centroids)
    n_nodes = lo.shape[0]
    centre = np.empty((n_nodes, 3))
    ptr = np.zeros(n_nodes + 1, dtype=np.int64)
    parts = []
    for node in range(n_nodes):
        ids = order[span[node, 0]:span[node, 0] + span[node, 1]]
        for k in range(3):
            lo[node, k], hi[node, k] = np.inf, -np.inf
            for f in ids:
                for j in range(3):
                    lo[node, k] = min(lo[node, k], points[faces[f, j], k])
                    hi[node, k] = max(hi[node, k], points[faces[f, j], k])
            centre[node, k] = 0.5 * (lo[node, k] + hi[node, k])
        edges = _boundary(faces, ids, points.shape[0])
        parts.append(edges)
        ptr[node + 1] = ptr[node] + edges.shape[0]
    edges = np.empty((ptr[-1], 2), dtype=np.int64)
    for node in range(n_nodes):
        edges[ptr[node]:ptr[node + 1]] = parts[node]
    return order, lo, hi, child, span, centre, ptr, edges


@njit(cache=True)
def tree_winding(points: np.ndarray, faces: np.ndarray, order: np.ndarray, lo: np.ndarray,
                 hi: np.ndarray, child: np.ndarray, span: np.ndarray, centre: np.ndarray,
                 ptr: np.ndarray, edges: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """(n,) winding numbers at `queries` (n, 3) from the tables of `build_tables`."""
    out = np.zeros(queries.shape[0])
    stack = np.empty(max(1, lo.shape[0]), dtype=np.int64)
    for i in range(queries.shape[0]):
        qx, qy, qz = queries[i, 0], queries[i, 1], queries[i, 2]
        s = 0.0
        top = 1
        stack[0] = 0
        while top > 0:
            top -= 1
            node = stack[top]
            outside = (qx < lo[node, 0] or qx > hi[node, 0] or qy < lo[node, 1]
                       or qy > hi[node, 1] or qz < lo[node, 2] or qz > hi[node, 2])
            if outside and ptr[node + 1] - ptr[node] <= span[node, 1]:
                c = centre[node]
                for e in range(ptr[node], ptr[node + 1]):
                    s += _solid_angle(qx, qy, qz, c, points[edges[e, 0]], points[edges[e, 1]])
            elif child[node, 0] < 0:
                for f in order[span[node, 0]:span[node, 0] + span[node, 1]]:
                    s += _solid_angle(qx, qy, qz, points[faces[f, 0]], points[faces[f, 1]],
                                      points[faces[f, 2]])
            else:
                stack[top] = child[node, 0]
                stack[top + 1] = child[node, 1]
                top += 2
        out[i] = s / FOUR_PI
    return out


class WindingTree:
    """The hierarchical winding number of one triangle mesh (its frame, mm), the tree
    built once (module docstring).

    >>> from geometry.mesh import TriMesh
    >>> cube = np.array([[x, y, z] for x in (0., 1) for y in (0., 1) for z in (0., 1)])
    >>> quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4),
    ...          (1, 5, 7, 3)]
    >>> tri = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    >>> WindingTree(TriMesh(cube, tri))(np.array([[0.5, 0.5, 0.5], [2.0, 0.5, 0.5]])).round(12)
    array([1., 0.])
    """

    def __init__(self, mesh) -> None:
        self._points = np.ascontiguousarray(mesh.points, dtype=float)
        self._faces = np.ascontiguousarray(mesh.faces, dtype=np.int64)
        self._tables = build_tables(self._points, self._faces)
        self(np.zeros((0, 3)))                  # load the query kernel now, not in a solve

    def __call__(self, queries: np.ndarray) -> np.ndarray:
        """(n,) winding numbers at points (n, 3) (the mesh's frame, mm)."""
        q = np.ascontiguousarray(np.asarray(queries, dtype=float).reshape(-1, 3))
        return tree_winding(self._points, self._faces, *self._tables, q)


SIDE_SLACK_MM = 1e-9
"""`same_side` asks a point to stay this much (mm) inside the ball it certifies, far above
the rounding of coordinates and distances (~1e-14 mm at 100 mm)."""


def same_side(y: np.ndarray, y0: np.ndarray, d0: np.ndarray) -> np.ndarray:
    """(n,) True where points y (n, 3) are certainly on the same side of a closed mesh as
    points y0 (n, 3) at distances ±d0 (n,) from it (mm): |y - y0| < |d0| - slack. The
    open ball of radius |d0| about y0 holds no surface, so the segment from y0 to y
    crosses none, and the winding number of a closed mesh, an integer off the surface,
    is the same at both ends (self-intersections included)."""
    moved = np.sqrt(((y - y0) ** 2).sum(axis=1))
    return moved < np.abs(d0) - SIDE_SLACK_MM


class SideGrid:
    """The side of a closed mesh (inside: winding number > 1/2) at the nodes of a grid
    over its box grown by `GRID_PAD_MM`, with each node's distance to the mesh: a point
    within a node's empty ball is on its side (`same_side`). With a 1 mm spacing every
    point of the box over 1.73 mm (a cell's diagonal) from the mesh is answered, and most
    points over half that."""

    @staticmethod
    def tables(points: np.ndarray, spacing_mm: float, distance, winding
               ) -> tuple[np.ndarray, ...]:
        """(origin and spacing (4,), node counts (3,), distances (N,) mm, inside (N,))
        of the grid over `points` (a mesh's vertices; `distance`, `winding`: functions of
        (N, 3) points), `spacing_mm` apart or wider over a box that would need more than
        `GRID_NODES` nodes."""
        lo = points.min(axis=0) - GRID_PAD_MM
        extent = points.max(axis=0) + GRID_PAD_MM - lo
        spacing_mm = max(spacing_mm, float(np.cbrt(np.prod(extent) / GRID_NODES)))
        count = np.ceil(extent / spacing_mm).astype(np.int64)
        count += 1
        axes = [lo[k] + spacing_mm * np.arange(count[k]) for k in range(3)]
        nodes = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        return (np.append(lo, spacing_mm), count, distance(nodes), winding(nodes) > 0.5)

    @staticmethod
    def sides(frame: np.ndarray, count: np.ndarray, distance: np.ndarray,
              inside: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(answered (n,), inside (n,), valid where answered) at points y (n, 3) from the
        tables of `tables`, each point by its nearest node."""
        lo, h = frame[:3], frame[3]
        idx = np.rint((y - lo) / h).astype(np.int64)
        within = np.all((idx >= 0) & (idx < count), axis=1)
        idx = np.clip(idx, 0, count - 1)
        flat = np.ravel_multi_index(idx.T, count)
        answered = within & same_side(y, lo + h * idx, distance[flat])
        return answered, inside[flat]

    @staticmethod
    def bounds(frame: np.ndarray, count: np.ndarray, distance: np.ndarray,
               inside: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) (n,) bounds of the signed distance (mm, positive inside) at points
        y (n, 3) from their nearest nodes: φ(node) ∓ |y - node| (φ is 1-Lipschitz: its
        sign turns only on the surface); (-inf, inf) off the grid."""
        lo, h = frame[:3], frame[3]
        idx = np.rint((y - lo) / h).astype(np.int64)
        within = np.all((idx >= 0) & (idx < count), axis=1)
        idx = np.clip(idx, 0, count - 1)
        flat = np.ravel_multi_index(idx.T, count)
        phi = np.where(inside[flat], distance[flat], -distance[flat])
        gap = np.sqrt(((y - (lo + h * idx)) ** 2).sum(axis=1)) + SIDE_SLACK_MM
        return (np.where(within, phi - gap, -np.inf), np.where(within, phi + gap, np.inf))
