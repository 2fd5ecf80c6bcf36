"""A bounding-volume hierarchy over a slave's vertices, built once per body, and the
broad phase's region queries against it.

A from-scratch broad phase used to move every slave vertex into the master frame and
test it (cost ∝ all vertices). The tree (axis-aligned boxes in the slave's own frame,
median splits on the longest axis, leaves of at most `LEAF` points) is built once per
slave mesh; a query descends only into boxes that can meet the master's region, so it
costs ∝ the vertices near the master plus the depth of the tree. Regions, in the master
frame (y = R p + t for a slave point p; mm):

* `HALF_SPACE` (plane master): n·y < c, params (n0, n1, n2, c);
* `BALL` (sphere master): |y − m| < r, params (m0, m1, m2, r);
* `BOX` (any master with a bounding box): lo ≤ y ≤ hi, params (lo0, lo1, lo2, hi0, hi1, hi2).

`select_faces` then turns the vertices found into the candidate faces (every face with
such a vertex), in face order, through a vertex-to-face table built once, and gathers
their data.
"""

from __future__ import annotations

import numpy as np
from numba import njit

LEAF = 8
HALF_SPACE, BALL, BOX = 0, 1, 2
_BIT = np.array([0, 1, 28, 2, 29, 14, 24, 3, 30, 22, 20, 15, 25, 17, 4, 8, 31, 27, 13, 23, 21,
                 19, 16, 7, 26, 12, 18, 6, 11, 5, 10, 9], dtype=np.int64)
"""The position of a 32-bit word's single set bit b from (b · 0x077CB531) >> 27 (de Bruijn)."""


@njit(cache=True)
def build_tree(points: np.ndarray):
    """Tree arrays: order (n,) point indices grouped by leaf; per node lo (3,), hi (3,),
    left/right child (-1 at a leaf), first/count of its points in `order`."""
    n = points.shape[0]
    cap = max(1, 2 * n)                         # at most n leaves, 2n - 1 nodes
    lo = np.empty((cap, 3))
    hi = np.empty((cap, 3))
    child = np.full((cap, 2), -1, dtype=np.int64)
    span = np.zeros((cap, 2), dtype=np.int64)
    order = np.arange(n)
    stack = np.empty(cap, dtype=np.int64)
    span[0, 0], span[0, 1] = 0, n
    nodes, top = 1, 1
    stack[0] = 0
    while top > 0:
        top -= 1
        node = stack[top]
        first, count = span[node, 0], span[node, 1]
        idx = order[first:first + count]
        for k in range(3):
            lo[node, k] = points[idx[0], k] if count else 0.0
            hi[node, k] = lo[node, k]
            for i in idx:
                lo[node, k] = min(lo[node, k], points[i, k])
                hi[node, k] = max(hi[node, k], points[i, k])
        if count <= LEAF:
            continue
        axis = np.argmax(hi[node] - lo[node])
        order[first:first + count] = idx[np.argsort(points[idx, axis], kind="mergesort")]
        half = count // 2
        for side in range(2):
            child[node, side] = nodes
            span[nodes, 0] = first + side * half
            span[nodes, 1] = half if side == 0 else count - half
            stack[top] = nodes
            top += 1
            nodes += 1
    return order, lo[:nodes].copy(), hi[:nodes].copy(), child[:nodes].copy(), span[:nodes].copy()


@njit(cache=True, inline="always")
def _box_meets(kind: int, q: np.ndarray, R: np.ndarray, t: np.ndarray, lo: np.ndarray,
               hi: np.ndarray, node: int, grow: float) -> bool:
    """Can the slave-frame box [lo[node], hi[node]] meet the region? (conservative; `q` is
    the region's params moved into the slave frame for HALF_SPACE and BALL, see
    `_slave_params`, and those two grown by `grow` mm; the tables are indexed in place,
    as a row view would cost more than the test)."""
    if kind == HALF_SPACE:                     # min over the box of n_s·p < c_s
        low = 0.0
        for k in range(3):
            low += q[k] * (lo[node, k] if q[k] > 0.0 else hi[node, k])
        return low < q[3] + grow
    if kind == BALL:                           # squared distance from the centre < r²
        d2 = 0.0
        for k in range(3):
            gap = max(lo[node, k] - q[k], 0.0, q[k] - hi[node, k])
            d2 += gap * gap
        return d2 < (q[3] + grow) * (q[3] + grow)
    for k in range(3):                         # the box's master-frame AABB overlaps
        c = t[k]
        e = 0.0
        for j in range(3):
            c += R[k, j] * 0.5 * (lo[node, j] + hi[node, j])
            e += abs(R[k, j]) * 0.5 * (hi[node, j] - lo[node, j])
        if c + e < q[k] or c - e > q[3 + k]:
            return False
    return True


@njit(cache=True, inline="always")
def _box_inside(kind: int, q: np.ndarray, lo: np.ndarray, hi: np.ndarray, node: int) -> bool:
    """Does the region hold the whole slave-frame box [lo[node], hi[node]]? (HALF_SPACE and
    BALL, with `q` as in `_box_meets`; False for BOX, whose points `reach` decides)."""
    if kind == HALF_SPACE:                     # max over the box of n_s·p < c_s
        high = 0.0
        for k in range(3):
            high += q[k] * (hi[node, k] if q[k] > 0.0 else lo[node, k])
        return high < q[3]
    if kind == BALL:                           # the farthest corner is within r
        d2 = 0.0
        for k in range(3):
            gap = max(q[k] - lo[node, k], hi[node, k] - q[k])
            d2 += gap * gap
        return d2 < q[3] * q[3]
    return False


@njit(cache=True, inline="always")
def _point_in(kind: int, params: np.ndarray, y0: float, y1: float, y2: float) -> bool:
    """Is the master-frame point y in the region?"""
    if kind == HALF_SPACE:
        return params[0] * y0 + params[1] * y1 + params[2] * y2 < params[3]
    if kind == BALL:
        d0, d1, d2 = y0 - params[0], y1 - params[1], y2 - params[2]
        return d0 * d0 + d1 * d1 + d2 * d2 < params[3] * params[3]
    return (params[0] <= y0 <= params[3] and params[1] <= y1 <= params[4]
            and params[2] <= y2 <= params[5])


@njit(cache=True)
def _slave_params(kind: int, params: np.ndarray, R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The region in the slave frame (HALF_SPACE: n_s = Rᵀn, c_s = c − n·t; BALL: the
    centre Rᵀ(m − t)); BOX params stay in the master frame."""
    q = params.copy()
    if kind == HALF_SPACE:
        q[3] = params[3] - (params[0] * t[0] + params[1] * t[1] + params[2] * t[2])
        for k in range(3):
            q[k] = R[0, k] * params[0] + R[1, k] * params[1] + R[2, k] * params[2]
    elif kind == BALL:
        for k in range(3):
            q[k] = (R[0, k] * (params[0] - t[0]) + R[1, k] * (params[1] - t[1])
                    + R[2, k] * (params[2] - t[2]))
    return q


@njit(cache=True)
def query_into(kind: int, params: np.ndarray, R: np.ndarray, t: np.ndarray,
               points: np.ndarray, out: np.ndarray, order: np.ndarray, lo: np.ndarray,
               hi: np.ndarray, child: np.ndarray, span: np.ndarray) -> int:
    """Write the indices of the slave points p (slave frame, mm) with R p + t in the
    region (kind, params) of the master frame into out[:m] (unsorted; `out` is
    (n_points,) scratch space); m."""
    q = _slave_params(kind, params, R, t)
    stack = np.empty(64, dtype=np.int64)
    m, top = 0, 1
    stack[0] = 0
    while top > 0:
        top -= 1
        node = stack[top]
        if not _box_meets(kind, q, R, t, lo, hi, node, 0.0):
            continue
        first, count = span[node, 0], span[node, 1]
        if _box_inside(kind, q, lo, hi, node):
            for k in range(first, first + count):
                out[m] = order[k]
                m += 1
            continue
        if child[node, 0] >= 0:
            stack[top] = child[node, 0]
            stack[top + 1] = child[node, 1]
            top += 2
            continue
        for k in range(first, first + count):
            i = order[k]
            p0, p1, p2 = points[i, 0], points[i, 1], points[i, 2]
            y0 = R[0, 0] * p0 + R[0, 1] * p1 + R[0, 2] * p2 + t[0]
            y1 = R[1, 0] * p0 + R[1, 1] * p1 + R[1, 2] * p2 + t[1]
            y2 = R[2, 0] * p0 + R[2, 1] * p1 + R[2, 2] * p2 + t[2]
            if _point_in(kind, params, y0, y1, y2):
                out[m] = i
                m += 1
    return m


@njit(cache=True)
def query(kind: int, params: np.ndarray, R: np.ndarray, t: np.ndarray, points: np.ndarray,
          out: np.ndarray, order: np.ndarray, lo: np.ndarray, hi: np.ndarray,
          child: np.ndarray, span: np.ndarray) -> np.ndarray:
    """Indices (unsorted) of the slave points p (slave frame, mm) with R p + t in the
    region (kind, params) of the master frame (`query_into`, copied out of `out`)."""
    return out[:query_into(kind, params, R, t, points, out, order, lo, hi, child,
                           span)].copy()


@njit(cache=True)
def vertex_faces(faces: np.ndarray, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR table of the faces around each vertex: faces of vertex v are
    index[ptr[v]:ptr[v + 1]], in increasing order."""
    ptr = np.zeros(n_points + 1, dtype=np.int64)
    for f in range(faces.shape[0]):
        for j in range(3):
            ptr[faces[f, j] + 1] += 1
    for v in range(n_points):
        ptr[v + 1] += ptr[v]
    fill = ptr[:-1].copy()
    index = np.empty(ptr[-1], dtype=np.int64)
    for f in range(faces.shape[0]):
        for j in range(3):
            v = faces[f, j]
            index[fill[v]] = f
            fill[v] += 1
    return ptr, index


@njit(cache=True)
def _faces_around(near: np.ndarray, ptr: np.ndarray, index: np.ndarray,
                  face_bits: np.ndarray) -> np.ndarray:
    """The faces around the vertices `near`, each once, in increasing order (see
    `select_faces`; face_bits is left zero)."""
    first, last = face_bits.size, -1
    m = 0
    for v in near:
        for k in range(ptr[v], ptr[v + 1]):
            f = index[k]
            word, bit = f >> 5, np.int64(1) << (f & 31)
            if not face_bits[word] & bit:
                face_bits[word] |= bit
                first, last = min(first, word), max(last, word)
                m += 1
    picked = np.empty(m, dtype=np.int64)
    i = 0
    for word in range(first, last + 1):         # set bits, lowest first
        w = face_bits[word]
        face_bits[word] = 0
        while w:
            low = w & -w
            picked[i] = (word << 5) + _BIT[((low * 0x077CB531) & 0xFFFFFFFF) >> 27]
            i += 1
            w ^= low
    return picked


@njit(cache=True)
def select_faces(near: np.ndarray, faces: np.ndarray, ptr: np.ndarray, index: np.ndarray,
                 face_bits: np.ndarray, vertex_index: np.ndarray, points: np.ndarray,
                 normals: np.ndarray, areas: np.ndarray):
    """The faces with a vertex in `near` (vertex indices), in increasing order, with their
    data: (faces (m,), vertices (n,), corners (m, 3) as indices into `vertices`, points
    (n, 3), normals (m, 3), areas (m,)) gathered from the slave's points (n_points, 3),
    face normals (n_faces, 3) and areas (n_faces,).

    face_bits (n_faces / 32 + 1,) int64 zeros, a bit per face, and vertex_index
    (n_points,) -1 are scratch tables, left as they were found. The cost is ∝ the faces
    selected, plus a scan of the words of face_bits between the first and last face.
    """
    picked = _faces_around(near, ptr, index, face_bits)
    return gather_faces(picked, np.zeros(0, dtype=np.int64), faces, normals, areas, points,
                        vertex_index)


@njit(cache=True)
def owner_tables(faces: np.ndarray, order: np.ndarray):
    """Each face's owner, its corner first in tree order, and the faces grouped by owner:
    (pos (n_points,) tree position of each point; face_order (n_faces,) face indices
    sorted by their owner's position; owner_ptr (n_points + 1,) so that the faces owned by
    the point at tree position k are face_order[owner_ptr[k]:owner_ptr[k + 1]]; a face's
    position in face_order is its rank)."""
    n, m = order.size, faces.shape[0]
    pos = np.empty(n, dtype=np.int64)
    for k in range(n):
        pos[order[k]] = k
    owner = np.empty(m, dtype=np.int64)
    owner_ptr = np.zeros(n + 1, dtype=np.int64)
    for f in range(m):
        owner[f] = min(pos[faces[f, 0]], pos[faces[f, 1]], pos[faces[f, 2]])
        owner_ptr[owner[f] + 1] += 1
    for k in range(n):
        owner_ptr[k + 1] += owner_ptr[k]
    fill = owner_ptr[:-1].copy()
    face_order = np.empty(m, dtype=np.int64)
    for f in range(m):
        face_order[fill[owner[f]]] = f
        fill[owner[f]] += 1
    return pos, face_order, owner_ptr


@njit(cache=True, inline="always")
def _in(kind: int, q: np.ndarray, p: np.ndarray, i: int, grow: float) -> bool:
    """Is the slave-frame point p[i] in the HALF_SPACE or BALL region `q` (slave-frame
    params, see `_slave_params`) grown by `grow` mm?"""
    if kind == HALF_SPACE:
        return q[0] * p[i, 0] + q[1] * p[i, 1] + q[2] * p[i, 2] < q[3] + grow
    d0, d1, d2 = p[i, 0] - q[0], p[i, 1] - q[1], p[i, 2] - q[2]
    return d0 * d0 + d1 * d1 + d2 * d2 < (q[3] + grow) * (q[3] + grow)


@njit(cache=True)
def subtree_max(values: np.ndarray, span: np.ndarray) -> np.ndarray:
    """(n_nodes,) the largest of `values` (in tree order) over each node's points."""
    out = np.zeros(span.shape[0])
    for node in range(span.shape[0]):
        for k in range(span[node, 0], span[node, 0] + span[node, 1]):
            out[node] = max(out[node], values[k])
    return out


@njit(cache=True)
def owned_faces(kind: int, params: np.ndarray, R: np.ndarray, t: np.ndarray,
                points: np.ndarray, order: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                child: np.ndarray, span: np.ndarray, owner_ptr: np.ndarray,
                extent: np.ndarray, node_extent: np.ndarray, out: np.ndarray) -> int:
    """Write the ranks (`owner_tables`) of the faces owned by a point p whose R p + t is
    in a HALF_SPACE or BALL region (master frame) grown by the point's `extent` (in tree
    order: the farthest corner of the faces it owns, mm; `node_extent`: its largest
    over each node) into out[:m] (`out` (n_faces,) scratch space); m.

    So every face with a corner in the region is written: its owner is at most its
    extent away from that corner. The points of a subtree are consecutive in tree order,
    and so are the faces they own: a subtree inside the region writes one range of ranks
    without visiting its points. The ranks are written in increasing order, so that two
    sets list the faces they share in the same order. Cost ∝ the faces found.
    """
    q = _slave_params(kind, params, R, t)
    stack = np.empty(64, dtype=np.int64)
    m, top = 0, 1
    stack[0] = 0
    while top > 0:
        top -= 1
        node = stack[top]
        if not _box_meets(kind, q, R, t, lo, hi, node, node_extent[node]):
            continue
        first, count = span[node, 0], span[node, 1]
        if _box_inside(kind, q, lo, hi, node):
            for j in range(owner_ptr[first], owner_ptr[first + count]):
                out[m] = j
                m += 1
            continue
        if child[node, 0] >= 0:                 # the first child next: ranks ascend
            stack[top] = child[node, 1]
            stack[top + 1] = child[node, 0]
            top += 2
            continue
        for k in range(first, first + count):
            if _in(kind, q, points, order[k], extent[k]):
                for j in range(owner_ptr[k], owner_ptr[k + 1]):
                    out[m] = j
                    m += 1
    return m


@njit(cache=True)
def gather_faces(ranks: np.ndarray, face_order: np.ndarray, corners: np.ndarray,
                 normals: np.ndarray, areas: np.ndarray, points: np.ndarray,
                 vertex_index: np.ndarray):
    """The faces of `ranks` with their data, as `select_faces` gives them (in rank order),
    from the tables in rank order: corners (n_faces, 3), normals (n_faces, 3), areas
    (n_faces,); face_order maps a rank to its face index (empty: ranks are face
    indices). vertex_index (n_points,) -1 is scratch, left as it was found."""
    m = ranks.size
    picked = np.empty(m, dtype=np.int64)
    vertices = np.empty(3 * m, dtype=np.int64)
    local = np.empty((m, 3), dtype=np.int64)
    out_normals = np.empty((m, 3))
    out_areas = np.empty(m)
    n = 0
    for i in range(m):
        j = ranks[i]
        picked[i] = face_order[j] if face_order.size else j
        out_areas[i] = areas[j]
        for c in range(3):
            out_normals[i, c] = normals[j, c]
            v = corners[j, c]
            if vertex_index[v] < 0:
                vertex_index[v] = n
                vertices[n] = v
                n += 1
            local[i, c] = vertex_index[v]
    out_points = np.empty((n, 3))
    for i in range(n):
        v = vertices[i]
        vertex_index[v] = -1
        for c in range(3):
            out_points[i, c] = points[v, c]
    return picked, vertices[:n], local, out_points, out_normals, out_areas


@njit(cache=True)
def query_faces(kind: int, params: np.ndarray, R: np.ndarray, t: np.ndarray,
                points: np.ndarray, order: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                child: np.ndarray, span: np.ndarray, owner_ptr: np.ndarray,
                extent: np.ndarray, node_extent: np.ndarray, out: np.ndarray,
                face_order: np.ndarray, corners: np.ndarray, normals: np.ndarray,
                areas: np.ndarray, vertex_index: np.ndarray):
    """`owned_faces` then `gather_faces` of the faces found, in one call."""
    m = owned_faces(kind, params, R, t, points, order, lo, hi, child, span, owner_ptr,
                    extent, node_extent, out)
    return gather_faces(out[:m], face_order, corners, normals, areas, points, vertex_index)


class PointTree:
    """The tree over a slave's points (slave frame, mm) and its face tables, built once;
    `near(kind, params, R, t)` gives the points in a master-frame region, `faces_of`
    the faces around given points, `faces_in` (at least) the faces with a corner in a
    half-space or ball, found through their owners (`owned_faces`).

    normals (n_faces, 3), areas (n_faces,): per-face data that `faces_of` and
    `faces_in` gather.
    """

    def __init__(self, points: np.ndarray, faces: np.ndarray, normals: np.ndarray,
                 areas: np.ndarray) -> None:
        self.points = np.ascontiguousarray(points, dtype=float)
        self.faces = np.ascontiguousarray(faces, dtype=np.int64)
        self.normals = np.ascontiguousarray(normals, dtype=float)
        self.areas = np.ascontiguousarray(areas, dtype=float)
        self.tables = build_tree(self.points)      # order, lo, hi, child, span
        self.ptr, self.index = vertex_faces(self.faces, len(self.points))
        self.face_bits = np.zeros(len(self.faces) // 32 + 1, dtype=np.int64)
        self.vertex_index = np.full(len(self.points), -1, dtype=np.int64)
        self.scratch = np.empty(len(self.points), dtype=np.int64)
        # faces by owner (`owner_tables`), their data in that order, the owners' extents
        self.pos, face_order, self.owner_ptr = owner_tables(self.faces, self.tables[0])
        self.ranked = (face_order, self.faces[face_order], self.normals[face_order],
                       self.areas[face_order])
        owner = np.repeat(np.arange(len(self.points)), np.diff(self.owner_ptr))
        reach = np.linalg.norm(self.points[self.ranked[1]]
                               - self.points[self.tables[0][owner]][:, None], axis=2)
        self.extent = np.zeros(len(self.points))
        np.maximum.at(self.extent, owner, reach.max(axis=1, initial=0.0))
        self.node_extent = subtree_max(self.extent, self.tables[4])
        self.face_scratch = np.empty(len(self.faces), dtype=np.int64)
        self.faces_of(self.near(BOX, np.zeros(6), np.eye(3), np.zeros(3)))   # load the
        self.faces_in(BALL, np.zeros(4), np.eye(3), np.zeros(3))   # kernels now, not in a solve

    @property
    def owned_tables(self) -> tuple:
        """The arguments of `query_faces` after (kind, params, R, t)."""
        return (self.points, *self.tables, self.owner_ptr, self.extent, self.node_extent,
                self.face_scratch, *self.ranked, self.vertex_index)

    def near(self, kind: int, params: np.ndarray, R: np.ndarray, t: np.ndarray) -> np.ndarray:
        """(k,) indices of the points with R p + t in the region, unsorted."""
        return query(kind, params, R, t, self.points, self.scratch, *self.tables)

    def faces_in(self, kind: int, params: np.ndarray, R: np.ndarray, t: np.ndarray):
        """The faces owned by a point p whose R p + t is in a HALF_SPACE or BALL region
        grown by p's extent (`owned_faces`): every face with a corner in the region and
        some near it; with their data as `faces_of` gives them (`query_faces`, one
        compiled call; in owner order, not sorted)."""
        return query_faces(kind, params, R, t, *self.owned_tables)

    def faces_of(self, near: np.ndarray):
        """`select_faces` of the vertices `near`: (faces, vertices, local corners,
        points, normals, areas)."""
        return select_faces(near, self.faces, self.ptr, self.index, self.face_bits,
                            self.vertex_index, self.points, self.normals, self.areas)
