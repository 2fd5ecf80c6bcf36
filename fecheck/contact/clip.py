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
_CYCLE = np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1]])
# Rows: barycentric coordinates of the 3 rule points on a sub-triangle's corners.
_RULE = np.array([[4.0, 1.0, 1.0], [1.0, 4.0, 1.0], [1.0, 1.0, 4.0]]) / 6.0


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
    positive = depth > 0.0
    n_pos = positive.sum(axis=1)
    # The odd vertex: the lone positive one (n_pos == 1) or the lone non-positive one.
    odd = np.where(n_pos == 1, np.argmax(positive, axis=1), np.argmin(positive, axis=1))
    perm = _CYCLE[odd]
    d = np.take_along_axis(depth, perm, axis=1)
    e_o, e_a, e_b = _EYE[perm[:, 0]], _EYE[perm[:, 1]], _EYE[perm[:, 2]]
    with np.errstate(divide="ignore", invalid="ignore"):  # unused where signs agree
        t_a = (d[:, 0] / (d[:, 0] - d[:, 1]))[:, None]
        t_b = (d[:, 0] / (d[:, 0] - d[:, 2]))[:, None]
        p_a = (1.0 - t_a) * e_o + t_a * e_a
        p_b = (1.0 - t_b) * e_o + t_b * e_b

    one, two, three = n_pos == 1, n_pos == 2, n_pos == 3
    idx = np.arange(len(depth))
    parent = np.concatenate([idx[three], idx[one], idx[two], idx[two]])
    corners = np.concatenate([
        np.stack([e_o[three], e_a[three], e_b[three]], axis=1),
        np.stack([e_o[one], p_a[one], p_b[one]], axis=1),
        np.stack([e_a[two], e_b[two], p_b[two]], axis=1),
        np.stack([e_a[two], p_b[two], p_a[two]], axis=1),
    ])
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
