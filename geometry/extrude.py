"""A layer of tetrahedra under a surface: the surface extruded along its inward normals.

Each vertex v of the articular surface (outward normals) is copied ``layers`` times
along its inward unit vertex normal -n_v, down to its own depth h_v (the local layer
thickness, mm), with level spacing graded geometrically from the top (``ratio`` > 1 puts
thin levels under the surface, where the contact pressure varies fastest). Each
triangle then spans ``layers`` prisms, and each prism is split into three tetrahedra by
the rule of sorted vertex indices: a quadrilateral side (p, q) with p < q is cut along
the diagonal p₀–q₁ (lower level of p to upper level of q) in both prisms that share it,
so the tetrahedra are conforming without any search. A uniform h measured along the
normal gives a layer whose top is the surface and whose bottom is the surface offset by
h (exact for a plane, to O(h·curvature) elsewhere).

>>> import numpy as np
>>> from geometry.mesh import TriMesh
>>> sheet = TriMesh(np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]),
...                 np.array([[0, 1, 3], [0, 3, 2]]))
>>> layer = extrude_layer(sheet, 2.0, layers=3)
>>> len(layer.tets), round(layer.volume, 12)
(18, 2.0)
"""

from __future__ import annotations

import numpy as np

from geometry.errors import FecheckError
from geometry.mesh import TetMesh, TriMesh

# Corner pattern of the 3 tetrahedra of a prism with sorted triangle (a < b < c);
# index k < 3 is the upper (surface) copy of corner k, k + 3 its lower copy. _SIGNS:
# each one's volume sign when (a, b, c) runs counter-clockwise seen from outside.
_PRISM_TETS = np.array([[0, 1, 2, 5], [0, 1, 4, 5], [0, 3, 4, 5]])
_SIGNS = np.array([-1.0, 1.0, -1.0])


def level_fractions(layers: int, ratio: float = 1.0) -> np.ndarray:
    """(layers + 1,) depths of the levels as fractions of the thickness, 0 (surface) to 1,
    each level ``ratio`` times thicker than the one above it."""
    if layers < 1:
        raise FecheckError(f"a layer needs at least one level of elements, got {layers}")
    if not (np.isfinite(ratio) and ratio > 0):
        raise FecheckError(f"level grading ratio must be positive, got {ratio}")
    widths = ratio ** np.arange(layers, dtype=float)
    return np.concatenate([[0.0], np.cumsum(widths) / widths.sum()])


def extrude_layer(surface: TriMesh, thickness_mm: float | np.ndarray, *, layers: int = 4,
                  ratio: float = 1.0) -> TetMesh:
    """Tetrahedral layer under `surface` (outward normals), `thickness_mm` deep along the
    inward vertex normals (a number, or one value per surface vertex).

    Returns a `TetMesh` whose first ``surface.n_points`` points are the surface's (level 0)
    and whose level-k copy of vertex v is point ``k·n + v``; boundaries ``"top"`` (the
    surface faces) and ``"bottom"`` (the deepest level, oriented outward, i.e. downward).
    """
    pts, tri = surface.points, surface.faces
    n = len(pts)
    h = np.broadcast_to(np.asarray(thickness_mm, dtype=float), (n,))
    if not np.all(np.isfinite(h)) or np.any(h <= 0):
        raise FecheckError("layer thickness must be finite and positive at every vertex (mm)")
    normals = surface.vertex_normals
    if np.any(np.linalg.norm(normals, axis=1) < 0.5):
        raise FecheckError("the surface has vertices without a normal (unused or degenerate "
                           "faces only): clean the mesh before extruding it")
    depth = level_fractions(layers, ratio)
    levels = pts[None] - depth[:, None, None] * (h[:, None] * normals)[None]
    points = levels.reshape(-1, 3)
    abc = np.sort(tri, axis=1)
    corners = np.concatenate([abc, abc + n], axis=1)                  # (m, 6): top, below
    tets = np.concatenate([corners[:, _PRISM_TETS] + k * n for k in range(layers)])
    tets = tets.reshape(-1, 4)
    expected = np.tile(np.outer(_parity(tri), _SIGNS).ravel(), layers)
    a, b, c, d = (points[tets[:, i]] for i in range(4))
    vol = np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a))
    if np.any(vol * expected <= 0.0):
        raise FecheckError("the extruded layer has inverted or flat tetrahedra: the thickness "
                           "is too large for the surface's curvature, or the surface folds")
    flip = expected < 0
    tets[flip] = tets[flip][:, [0, 2, 1, 3]]
    bottom = tri[:, [0, 2, 1]] + layers * n
    return TetMesh(points, tets, {"top": tri.copy(), "bottom": bottom})


def _parity(tri: np.ndarray) -> np.ndarray:
    """(m,) +1 where sorting a face's vertex indices is an even permutation (a rotation of
    the face, which keeps its orientation), -1 where it is odd (it reverses it)."""
    order = np.argsort(tri, axis=1)
    rotation = np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1]])
    even = (order[:, None, :] == rotation[None]).all(axis=2).any(axis=1)
    return np.where(even, 1.0, -1.0)
