"""Exact clipping of triangles at the zero line of a linear depth field, and quadrature.

Depth is linear on each face, so the in-contact part (depth > 0) is a triangle (one
vertex in contact), a quadrilateral split into two triangles (two vertices), or the
whole face (three). Sub-triangles are given by the barycentric coordinates of their
corners on the parent face; each carries the 3-point interior rule of degree 2
(points (2/3, 1/6, 1/6) and permutations, weights 1/3), exact for the quadratic
integrands of the linear elastic foundation and its tangent.
"""

from __future__ import annotations

import numpy as np

_EYE = np.eye(3)
# Rows: barycentric coordinates of the 3 rule points on a sub-triangle's corners.
_RULE = np.array([[4.0, 1.0, 1.0], [1.0, 4.0, 1.0], [1.0, 1.0, 4.0]]) / 6.0
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
_ROLL = [1, 2, 0]
_BITS = np.array([1, 2, 4])


def _corner_polynomials() -> tuple[np.ndarray, np.ndarray]:
    """Per corner point, its barycentric coordinates as a linear function of
    (1, t0, t1, t2): (6, 3, 4)."""
    lin = np.zeros((6, 3, 4))
    for i in range(3):
        lin[i, i, 0] = 1.0
        j = (i + 1) % 3                     # edge point i: (1 - t_i) e_i + t_i e_j
        lin[3 + i, i, 0] = 1.0
        lin[3 + i, i, 1 + i] = -1.0
        lin[3 + i, j, 1 + i] = 1.0
    return lin


def _tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per pattern: rule points (6, 3, 4) linear in (1, t0, t1, t2); sub-triangle area
    fractions (2, 7) as polynomials in (1, t0, t1, t2, t0·t1, t1·t2, t2·t0); which of
    the 6 rule points exist (6,). Each corner depends on at most one t and no two
    corners of a sub-triangle on the same t, so the area (a determinant multilinear in
    the corners) has only those monomials."""
    lin = _corner_polynomials()
    monomial = {(): 0, (0,): 1, (1,): 2, (2,): 3, (0, 1): 4, (1, 2): 5, (0, 2): 6}
    points = np.zeros((8, 6, 3, 4))
    area = np.zeros((8, 2, 7))
    valid = np.zeros((8, 6), dtype=bool)
    for pattern in range(8):
        for slot in range(2):
            corners = _TABLE[pattern, slot]
            if corners[0] < 0:
                continue
            c = lin[corners]                                  # (3 corners, 3, 4)
            points[pattern, 3 * slot:3 * slot + 3] = np.einsum("qc,cjk->qjk", _RULE, c)
            valid[pattern, 3 * slot:3 * slot + 3] = True
            # Expand det[c0; c1; c2] row by row: constant part or the t part of a row.
            edge = [int(np.flatnonzero(np.abs(ci[:, 1:]).sum(axis=0))[0])
                    if np.abs(ci[:, 1:]).any() else None for ci in c]
            for choice in np.ndindex(2, 2, 2):
                if any(ch and e is None for ch, e in zip(choice, edge)):
                    continue
                rows = [ci[:, 1 + e] if ch else ci[:, 0] for ci, ch, e in zip(c, choice, edge)]
                ts = tuple(sorted(e for ch, e in zip(choice, edge) if ch))
                area[pattern, slot, monomial[ts]] += np.linalg.det(np.array(rows))
    return points, area, valid


_POINTS, _AREA, _VALID = _tables()


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
    pattern = (depth > 0.0) @ _BITS
    step = depth - depth[:, _ROLL]
    t = depth / np.where(step == 0.0, 1.0, step)        # zero crossing along edge e → e+1
    mono = np.concatenate([np.ones((len(depth), 1)), t, t * t[:, _ROLL]], axis=1)
    points = np.einsum("fqjk,fk->fqj", _POINTS[pattern], mono[:, :4])
    fraction = np.abs(np.einsum("fsk,fk->fs", _AREA[pattern], mono)) / 3.0
    face, slot = np.nonzero(_VALID[pattern])
    return face, points[face, slot], fraction[face, slot // 3]


def whole_face_quadrature(n_faces: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Degree-2 rule on the whole of every face (the thesis's counting)."""
    return (np.repeat(np.arange(n_faces), 3), np.tile(_RULE, (n_faces, 1)),
            np.full(3 * n_faces, 1.0 / 3.0))
