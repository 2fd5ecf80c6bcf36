"""Points located in a 2-D triangulation: which triangle, barycentric coordinates, and
the sparse interpolation from its vertex values to the points. Coordinates in mm (any
in-plane frame); shared by the sheet preparation (`geometry.prepare`) and the voxel
terrace fit (`geometry.terraces`)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

NEAREST = 16
"""Triangles (by nearest centroid) searched for each query point."""


def inside_triangulation(points: np.ndarray, uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(n,) True where a point (n, 2) lies in one of the projected triangles uv[faces]."""
    tri = uv[faces]                                                    # (m, 3, 2)
    k = min(NEAREST, len(faces))
    _, near = cKDTree(tri.mean(axis=1)).query(points, k=k)
    near = near.reshape(len(points), k)
    bary = barycentric_2d(tri[near], points[:, None, :])              # (n, k, 3)
    return (bary >= -1e-9).all(axis=2).any(axis=1)


def barycentric_2d(tri: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (..., 3) of 2-D points p (..., 2) in triangles (..., 3, 2);
    -1 for a triangle of zero area."""
    a, b, c = tri[..., 0, :], tri[..., 1, :], tri[..., 2, :]
    det = (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) \
        - (c[..., 0] - a[..., 0]) * (b[..., 1] - a[..., 1])
    ok = np.abs(det) > 1e-14
    safe = np.where(ok, det, 1.0)
    v = ((p[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1])
         - (c[..., 0] - a[..., 0]) * (p[..., 1] - a[..., 1])) / safe
    w = ((b[..., 0] - a[..., 0]) * (p[..., 1] - a[..., 1])
         - (p[..., 0] - a[..., 0]) * (b[..., 1] - a[..., 1])) / safe
    out = np.stack([1.0 - v - w, v, w], axis=-1)
    return np.where(ok[..., None], out, -1.0)


def plane_interpolation(points: np.ndarray, faces: np.ndarray, query: np.ndarray
                        ) -> sp.csr_matrix:
    """(k, n) barycentric interpolation from a 2-D triangulation's vertex values to the
    query points (k, 2); the nearest vertex for points outside it."""
    face, w, inside = locate_in_plane(points, faces, query)
    _, nearest = cKDTree(points).query(query)
    cols = np.where(inside[:, None], faces[face], nearest[:, None])
    vals = np.where(inside[:, None], w, np.array([1.0, 0.0, 0.0]))
    rows = np.repeat(np.arange(len(query)), 3)
    return sp.csr_matrix((vals.ravel(), (rows, cols.ravel())),
                         shape=(len(query), len(points)))


def locate_in_plane(points: np.ndarray, faces: np.ndarray, query: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each query point (k, 2): the triangle of a 2-D triangulation it lies in (or
    comes closest to), its barycentric coordinates there (k, 3), and whether it is inside."""
    tri = points[faces]
    k = min(NEAREST, len(faces))
    _, near = cKDTree(tri.mean(axis=1)).query(query, k=k)
    near = near.reshape(len(query), k)
    bary = barycentric_2d(tri[near], query[:, None, :])                # (q, k, 3)
    worst = bary.min(axis=2)
    best = np.argmax(worst, axis=1)
    rows = np.arange(len(query))
    return near[rows, best], bary[rows, best], worst[rows, best] >= -1e-9
