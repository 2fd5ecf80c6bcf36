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
# edges 0-1, 1-2, 2-0. For each sign pattern (bit i set when vertex i is in contact),
# the in-contact sub-triangles as corner-point triples (unused slots are never read).
_N_TRI = np.array([0, 1, 1, 2, 1, 2, 2, 1])
_TABLE = np.array([
    [[0, 0, 0], [0, 0, 0]],
    [[0, 3, 5], [0, 0, 0]],      # vertex 0
    [[1, 4, 3], [0, 0, 0]],      # vertex 1
    [[0, 1, 4], [0, 4, 5]],      # vertices 0, 1
    [[2, 5, 4], [0, 0, 0]],      # vertex 2
    [[2, 0, 3], [2, 3, 4]],      # vertices 0, 2
    [[1, 2, 5], [1, 5, 3]],      # vertices 1, 2
    [[0, 1, 2], [0, 0, 0]],      # all three
])
_ROLL = [1, 2, 0]
_EDGE_POINTS = [3, 4, 5]
_BITS = np.array([1, 2, 4])


def clip_faces(depth: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sub-triangles of each face where its linear depth field is positive.

    Parameters
    ----------
    depth : (m, 3) vertex depths, mm; every face must have at least one positive value.

    Returns
    -------
    parent : (k,) index of the face each sub-triangle belongs to
    corners : (k, 3, 3) barycentric coordinates (on the parent) of the 3 corners
    fraction : (k,) sub-triangle area / parent face area

    >>> parent, corners, frac = clip_faces(np.array([[1.0, -1.0, -1.0]]))
    >>> float(frac[0])
    0.25
    """
    m = len(depth)
    pattern = (depth > 0.0) @ _BITS
    step = depth - depth[:, _ROLL]
    t = depth / np.where(step == 0.0, 1.0, step)      # zero crossing along edge i → i+1
    points = np.zeros((m, 6, 3))
    points[:, :3] = _EYE
    points[:, _EDGE_POINTS, [0, 1, 2]] = 1.0 - t
    points[:, _EDGE_POINTS, _ROLL] = t
    slots = np.flatnonzero(np.arange(2) < _N_TRI[pattern][:, None])
    parent = slots >> 1
    corners = points[parent[:, None], _TABLE[pattern[parent], slots & 1]]
    u = corners[:, 1, 1:] - corners[:, 0, 1:]
    v = corners[:, 2, 1:] - corners[:, 0, 1:]
    fraction = np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
    return parent, corners, fraction


def whole_faces(n_faces: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The whole of every face as one sub-triangle (the thesis's counting)."""
    parent = np.arange(n_faces)
    return parent, np.broadcast_to(_EYE, (n_faces, 3, 3)), np.ones(n_faces)


def quadrature(parent: np.ndarray, corners: np.ndarray, fraction: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Degree-2 rule on every sub-triangle.

    Returns (qp_face (3k,), qp_bary (3k, 3), qp_fraction (3k,)): parent face, barycentric
    coordinates on it and the point's share of the parent face's area.
    """
    bary = np.einsum("qc,kcj->kqj", _RULE, corners).reshape(-1, 3)
    return np.repeat(parent, 3), bary, np.repeat(fraction / 3.0, 3)
