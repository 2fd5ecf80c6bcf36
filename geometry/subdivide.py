"""Midpoint subdivision of a triangle surface: every triangle split into four.

Each face (a, b, c) gets the midpoints of its edges, one new vertex per unique edge
(shared with the neighbouring face, so the mesh stays conforming), and is replaced by
the three corner triangles and the middle one, all wound like the parent. The new
vertices lie on the flat parent faces: the surface, its area and its facing do not
change, only the resolution (edges halve per split). Units are those of the points (mm).

>>> import numpy as np
>>> from geometry.mesh import TriMesh
>>> square = TriMesh(np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]),
...                  np.array([[0, 1, 3], [0, 3, 2]]))
>>> fine, parent = subdivide(square, 2)
>>> fine.n_faces, fine.n_points, float(fine.area)
(32, 25, 1.0)
>>> np.bincount(parent).tolist()
[16, 16]
"""

from __future__ import annotations

import numpy as np

from geometry.errors import FecheckError
from geometry.mesh import TriMesh


def subdivide(surface: TriMesh, times: int) -> tuple[TriMesh, np.ndarray]:
    """`surface` with every triangle split into 4 at its edge midpoints, `times` times.

    Parameters
    ----------
    surface : triangle mesh (mm)
    times : number of splits, >= 0 (0 gives a copy)

    Returns
    -------
    mesh : 4^times · m faces; its first ``surface.n_points`` points are the original
        vertices in the same order, then one midpoint per unique edge; faces keep the
        parent's winding; regions (face index sets) are carried to the children
    parent : (4^times · m,) index of the original face each new face lies in
    """
    if int(times) != times or times < 0:
        raise FecheckError(f"subdivision count must be a whole number >= 0, got {times}")
    points, faces = surface.points.copy(), surface.faces.copy()
    parent = np.arange(surface.n_faces)
    regions = {name: np.asarray(f).copy() for name, f in surface.regions.items()}
    for _ in range(int(times)):
        points, faces = _split(points, faces)
        parent = np.repeat(parent, 4)
        regions = {name: (4 * f[:, None] + np.arange(4)).ravel() for name, f in regions.items()}
    return TriMesh(points, faces, regions), parent


def _split(points: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One midpoint split: (n + e, 3) points and (4m, 3) faces, the four children of face
    i at rows 4i … 4i + 3 (corners at a, b, c, then the middle one)."""
    n = len(points)
    edges = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)              # ab, bc, ca per face
    unique, index = np.unique(np.sort(edges, axis=1), axis=0, return_inverse=True)
    mid = n + index.reshape(-1, 3)                                   # (m, 3): ab, bc, ca
    a, b, c = faces.T
    ab, bc, ca = mid.T
    children = np.stack([np.stack([a, ab, ca], 1), np.stack([ab, b, bc], 1),
                         np.stack([ca, bc, c], 1), np.stack([ab, bc, ca], 1)], axis=1)
    midpoints = 0.5 * (points[unique[:, 0]] + points[unique[:, 1]])
    return np.vstack([points, midpoints]), children.reshape(-1, 3)
