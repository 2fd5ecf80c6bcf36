"""Exact clipping of triangles at the zero line of a linear depth field, and quadrature.

Depth is linear on each face, so the in-contact part (depth > 0) is a triangle (one
vertex in contact), a quadrilateral split into two triangles (two vertices), or the
whole face (three). Sub-triangles are given by the barycentric coordinates of their
corners on the parent face; each carries the 3-point interior rule of degree 2
(points (2/3, 1/6, 1/6) and permutations, weights 1/3), exact for the quadratic
integrands of the linear elastic foundation and its tangent.

The per-face rule `face_rule` is compiled with numba: the contact kernels of
`fecheck.contact.kernels` call it face by face; `clipped_quadrature` applies it to an
array of faces. On a clipped face the rule's points and weights move with the clip
line as the vertex depths change; `clip_line_motion` gives that motion, which the
tangent of a nonlinear law needs (for the linear law its contributions cancel: the
rule is exact for the law's quadratic integrands, which vanish on the clip line).
"""

from __future__ import annotations

import numpy as np
from numba import njit

# Rows: barycentric coordinates of the 3 rule points on a sub-triangle's corners.
RULE = np.array([[4.0, 1.0, 1.0], [1.0, 4.0, 1.0], [1.0, 1.0, 4.0]]) / 6.0
# Corner points of a face: 0, 1, 2 its vertices, 3, 4, 5 the zero-depth points on the
# edges 0→1, 1→2, 2→0 (at parameter t_e = d_e / (d_e - d_{e+1}) from vertex e). For
# each sign pattern (bit i set when vertex i is in contact), the in-contact
# sub-triangles as corner-point triples; unused second slots are marked -1.
_TABLE = np.array([
    [[-1, -1, -1], [-1, -1, -1]],
    [[0, 3, 5], [-1, -1, -1]],   # vertex 0
    [[1, 4, 3], [-1, -1, -1]],   # vertex 1
    [[0, 1, 4], [0, 4, 5]],      # vertices 0, 1
    [[2, 5, 4], [-1, -1, -1]],   # vertex 2
    [[2, 0, 3], [2, 3, 4]],      # vertices 0, 2
    [[1, 2, 5], [1, 5, 3]],      # vertices 1, 2
    [[0, 1, 2], [-1, -1, -1]],   # all three
])
# Number of rule points per sign pattern (3 per sub-triangle).
N_POINTS = np.array([0, 3, 3, 6, 3, 6, 6, 3])


@njit(cache=True, fastmath=False, inline="always")
def pattern_of(d0: float, d1: float, d2: float) -> int:
    """Sign pattern of a face: bit i set when vertex i has a positive depth."""
    return (d0 > 0.0) + 2 * (d1 > 0.0) + 4 * (d2 > 0.0)


@njit(cache=True, fastmath=False, inline="always")
def face_rule(d0: float, d1: float, d2: float, bary: np.ndarray, fraction: np.ndarray,
              start: int, corner: np.ndarray) -> int:
    """Degree-2 rule on the positive part of one face with vertex depths d0, d1, d2 (mm).

    Writes the points' barycentric coordinates into ``bary[start:]`` and their weights as
    fractions of the face's area into ``fraction[start:]``; returns the next free row.
    `corner` (6, 3) is scratch space.
    """
    pattern = pattern_of(d0, d1, d2)
    if pattern == 7:                                # the whole face: the rule itself
        for q in range(3):
            for k in range(3):
                bary[start + q, k] = RULE[q, k]
            fraction[start + q] = 1.0 / 3.0
        return start + 3
    d = (d0, d1, d2)
    corner[:] = 0.0
    for i in range(3):
        j = (i + 1) % 3
        step = d[i] - d[j]
        t = d[i] / (step if step != 0.0 else 1.0)   # zero crossing along edge i → j
        corner[i, i] = 1.0
        corner[3 + i, i] = 1.0 - t
        corner[3 + i, j] = t
    row = start
    for slot in range(2):
        c0, c1, c2 = _TABLE[pattern, slot, 0], _TABLE[pattern, slot, 1], _TABLE[pattern, slot, 2]
        if c0 < 0:
            continue
        a0, a1, a2 = corner[c0, 0], corner[c0, 1], corner[c0, 2]
        b0, b1, b2 = corner[c1, 0], corner[c1, 1], corner[c1, 2]
        e0, e1, e2 = corner[c2, 0], corner[c2, 1], corner[c2, 2]
        det = a0 * (b1 * e2 - b2 * e1) - a1 * (b0 * e2 - b2 * e0) + a2 * (b0 * e1 - b1 * e0)
        for q in range(3):
            r0, r1, r2 = RULE[q, 0], RULE[q, 1], RULE[q, 2]
            bary[row, 0] = r0 * a0 + r1 * b0 + r2 * e0
            bary[row, 1] = r0 * a1 + r1 * b1 + r2 * e1
            bary[row, 2] = r0 * a2 + r1 * b2 + r2 * e2
            fraction[row] = abs(det) / 3.0
            row += 1
    return row


@njit(cache=True, fastmath=False, inline="always")
def clip_line_motion(f: int, c: int, row: int, D: np.ndarray, X: np.ndarray, T: np.ndarray,
                     scale: float, corner: np.ndarray, slot: np.ndarray, rate: np.ndarray,
                     cof: np.ndarray, depth_twist: np.ndarray, weight_twist: np.ndarray,
                     qp_clip: np.ndarray, clip_share: np.ndarray, clip_edge: np.ndarray,
                     clip_rate: np.ndarray) -> None:
    """The motion of `face_rule`'s points on face f, cut by the clip line.

    The zero-depth point on a cut edge i → j sits at t = d_i/(d_i − d_j) from X_i, so it
    moves by (X_j − X_i)·∂t/∂ξ. Writes, as cut face number c: the cut edges' vectors
    ``clip_edge[c]`` (2, 3) mm and rates ``clip_rate[c]`` (2, 6) ∂t/∂ξ; for the face's
    points (rows from `row`) ``qp_clip`` = c and ``clip_share`` (their rule weights of
    each crossing point), so that a point slides in the face by Σ_e share_e·edge_e ⊗ rate_e.
    Overwrites the points' depth twists with the total derivative (the depth of a
    point is its rule's combination of the corners' depths, zero on the clip line) and
    adds the sub-triangle's area rate × `scale` (face area × weight per unit area) to
    their weight twists. `corner` is the scratch `face_rule` filled for this face;
    `slot` (3,) int, `rate` (6,) and `cof` (3, 3) are scratch.
    """
    _cut_edges(f, c, D, X, T, slot, clip_edge, clip_rate)
    pattern = pattern_of(D[f, 0], D[f, 1], D[f, 2])
    q = row
    for sub in range(2):
        ids = (_TABLE[pattern, sub, 0], _TABLE[pattern, sub, 1], _TABLE[pattern, sub, 2])
        if ids[0] < 0:
            continue
        sign = _det_rate(ids, corner, slot, clip_rate[c], rate, cof)
        for r in range(3):
            qp_clip[q] = c
            clip_share[q, 0] = clip_share[q, 1] = 0.0
            for k in range(6):
                depth_twist[q, k] = 0.0
                weight_twist[q, k] += scale * sign * rate[k] / 3.0
            for n in range(3):
                w = RULE[r, n]
                if ids[n] < 3:
                    for k in range(6):
                        depth_twist[q, k] += w * T[f, ids[n], k]
                else:
                    clip_share[q, slot[ids[n] - 3]] += w
            q += 1


@njit(cache=True, fastmath=False, inline="always")
def _cut_edges(f, c, D, X, T, slot, clip_edge, clip_rate):
    """Vectors and crossing rates ∂t/∂ξ of face f's cut edges; slot[i] = their order
    (0, 1) for edge i → i+1, −1 if not cut."""
    d = (D[f, 0], D[f, 1], D[f, 2])
    used = 0
    for i in range(3):
        j = (i + 1) % 3
        slot[i] = -1
        if (d[i] > 0.0) != (d[j] > 0.0):
            step = d[i] - d[j]
            ri, rj = -d[j] / (step * step), d[i] / (step * step)
            for k in range(6):
                clip_rate[c, used, k] = ri * T[f, i, k] + rj * T[f, j, k]
            for k in range(3):
                clip_edge[c, used, k] = X[f, j, k] - X[f, i, k]
            slot[i] = used
            used += 1


@njit(cache=True, fastmath=False, inline="always")
def _det_rate(ids, corner, slot, edge_rate, rate, cof):
    """Rate of the barycentric determinant of the sub-triangle with corners `ids` into
    `rate` (6,) (`cof` (3, 3) scratch); returns its sign. A corner on cut edge i → j
    moves by (e_j − e_i)·δt, which changes det = a · (b × e) by (cof_j − cof_i)·δt, cof
    the corner's cofactor row (b × e, e × a, a × b)."""
    a0, a1, a2 = corner[ids[0], 0], corner[ids[0], 1], corner[ids[0], 2]
    b0, b1, b2 = corner[ids[1], 0], corner[ids[1], 1], corner[ids[1], 2]
    e0, e1, e2 = corner[ids[2], 0], corner[ids[2], 1], corner[ids[2], 2]
    cof[0, 0], cof[0, 1], cof[0, 2] = b1 * e2 - b2 * e1, b2 * e0 - b0 * e2, b0 * e1 - b1 * e0
    cof[1, 0], cof[1, 1], cof[1, 2] = e1 * a2 - e2 * a1, e2 * a0 - e0 * a2, e0 * a1 - e1 * a0
    cof[2, 0], cof[2, 1], cof[2, 2] = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
    for k in range(6):
        rate[k] = 0.0
    for n in range(3):
        if ids[n] >= 3:
            i = ids[n] - 3
            g = cof[n, (i + 1) % 3] - cof[n, i]
            for k in range(6):
                rate[k] += g * edge_rate[slot[i], k]
    return 1.0 if a0 * cof[0, 0] + a1 * cof[0, 1] + a2 * cof[0, 2] >= 0.0 else -1.0


@njit(cache=True, fastmath=False)
def _clip_faces(depth: np.ndarray):
    n_q = 0
    for f in range(depth.shape[0]):
        n_q += N_POINTS[pattern_of(depth[f, 0], depth[f, 1], depth[f, 2])]
    face = np.empty(n_q, dtype=np.int64)
    bary = np.empty((n_q, 3))
    fraction = np.empty(n_q)
    corner = np.empty((6, 3))
    row = 0
    for f in range(depth.shape[0]):
        end = face_rule(depth[f, 0], depth[f, 1], depth[f, 2], bary, fraction, row, corner)
        face[row:end] = f
        row = end
    return face, bary, fraction


def clipped_quadrature(depth: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Degree-2 rule on the part of each face where its linear depth field is positive.

    Parameters
    ----------
    depth : (m, 3) vertex depths, mm; every face must have at least one positive value.

    Returns
    -------
    qp_face : (Q,) face of each point
    qp_bary : (Q, 3) barycentric coordinates of the point on its face
    qp_fraction : (Q,) the point's weight as a fraction of its face's area

    >>> face, bary, frac = clipped_quadrature(np.array([[1.0, -1.0, -1.0]]))
    >>> float(frac.sum())
    0.25
    """
    return _clip_faces(np.ascontiguousarray(depth, dtype=float))


def whole_face_quadrature(n_faces: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Degree-2 rule on the whole of every face (the thesis's counting)."""
    return (np.repeat(np.arange(n_faces), 3), np.tile(RULE, (n_faces, 1)),
            np.full(3 * n_faces, 1.0 / 3.0))
