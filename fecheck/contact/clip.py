"""Exact clipping of triangles at the zero line of a linear depth field, and quadrature.

Depth is linear on each face, so the in-contact part (depth > 0) is a triangle (one
vertex in contact), a quadrilateral split into two triangles (two vertices), or the
whole face (three). Sub-triangles are given by the barycentric coordinates of their
corners on the parent face; each carries the 3-point interior rule of degree 2
(points (2/3, 1/6, 1/6) and permutations, weights 1/3), exact for the quadratic
integrands of the linear elastic foundation and its tangent.

The per-face rule `face_rule` is compiled with numba: the contact kernels of
`fecheck.contact.kernels` call it face by face; `clipped_quadrature` applies it to an
array of faces.
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


@njit(cache=True, fastmath=False)
def pattern_of(d0: float, d1: float, d2: float) -> int:
    """Sign pattern of a face: bit i set when vertex i has a positive depth."""
    return (d0 > 0.0) + 2 * (d1 > 0.0) + 4 * (d2 > 0.0)


@njit(cache=True, fastmath=False)
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
