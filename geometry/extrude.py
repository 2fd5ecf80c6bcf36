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

On a curved or noisy surface the raw vertex normals cross within the layer and invert
prisms; `extrusion_directions` smooths them over the 1-ring until none is inverted, and
`extrude_layer(..., directions=...)` extrudes along those instead.

>>> import numpy as np
>>> from geometry.mesh import TriMesh
>>> sheet = TriMesh(np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]),
...                 np.array([[0, 1, 3], [0, 3, 2]]))
>>> layer = extrude_layer(sheet, 2.0, layers=3)
>>> len(layer.tets), round(layer.volume, 12)
(18, 2.0)
>>> d, rounds = extrusion_directions(sheet, 2.0, layers=3)
>>> d[0].tolist(), rounds
([0.0, 0.0, 1.0], 0)
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from geometry.errors import FecheckError
from geometry.mesh import TetMesh, TriMesh

# Corner pattern of the 3 tetrahedra of a prism with sorted triangle (a < b < c);
# index k < 3 is the upper (surface) copy of corner k, k + 3 its lower copy. _SIGNS:
# each one's volume sign when (a, b, c) runs counter-clockwise seen from outside.
_PRISM_TETS = np.array([[0, 1, 2, 5], [0, 1, 4, 5], [0, 3, 4, 5]])
_SIGNS = np.array([-1.0, 1.0, -1.0])
#: Smallest d·n used to stretch an extrusion along a direction d tilted from the normal n.
MIN_COSINE = 0.5
#: Total 1-ring smoothing rounds tried by `extrusion_directions`, in order.
ROUND_SCHEDULE = (0, 1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024)


def level_fractions(layers: int, ratio: float = 1.0) -> np.ndarray:
    """(layers + 1,) depths of the levels as fractions of the thickness, 0 (surface) to 1,
    each level ``ratio`` times thicker than the one above it."""
    if layers < 1:
        raise FecheckError(f"a layer needs at least one level of elements, got {layers}")
    if not (np.isfinite(ratio) and ratio > 0):
        raise FecheckError(f"level grading ratio must be positive, got {ratio}")
    widths = ratio ** np.arange(layers, dtype=float)
    return np.concatenate([[0.0], np.cumsum(widths) / widths.sum()])


def extrusion_offsets(surface: TriMesh, thickness_mm: float | np.ndarray,
                      directions: np.ndarray | None = None) -> np.ndarray:
    """(n, 3) vectors from each vertex's bottom copy up to the vertex, mm, as
    `extrude_layer` places them (along the normals, or along `directions` with the
    thickness kept along the normal)."""
    h, normals = _thickness(surface, thickness_mm), _normals(surface)
    return _offsets(h, normals, None if directions is None else _unit(directions,
                                                                        surface.n_points))


def extrude_layer(surface: TriMesh, thickness_mm: float | np.ndarray, *, layers: int = 4,
                  ratio: float = 1.0, directions: np.ndarray | None = None,
                  offsets: np.ndarray | None = None) -> TetMesh:
    """Tetrahedral layer under `surface` (outward normals), `thickness_mm` deep along the
    inward vertex normals (a number, or one value per surface vertex).

    `directions` : optional (n, 3) unit vectors on the outward side (like the vertex
    normals n_v) to extrude along instead, e.g. from `extrusion_directions`. The thickness
    h_v stays measured along the normal: vertex v goes h_v / (d_v·n_v) along -d_v, with
    d_v·n_v clipped below at `MIN_COSINE` (0.5), so its bottom copy lies h_v below the
    tangent plane wherever d_v is within 60° of n_v.

    `offsets` : optional (n, 3) vectors from each bottom copy up to its vertex (e.g. a
    coarser layer's `extrusion_offsets` interpolated onto a subdivided surface, which
    then extrudes into that layer subdivided); they replace thickness and directions.

    Returns a `TetMesh` whose first ``surface.n_points`` points are the surface's (level 0)
    and whose level-k copy of vertex v is point ``k·n + v``; boundaries ``"top"`` (the
    surface faces) and ``"bottom"`` (the deepest level, oriented outward, i.e. downward).
    Raises `FecheckError` when a tetrahedron comes out inverted or flat.
    """
    tri, n = surface.faces, surface.n_points
    if offsets is None:
        offsets = extrusion_offsets(surface, thickness_mm, directions)
    elif np.shape(offsets) != (n, 3) or not np.all(np.isfinite(offsets)):
        raise FecheckError(f"extrusion offsets must be a finite ({n}, 3) array")
    points = _levels(surface.points, offsets, level_fractions(layers, ratio))
    tets, expected = _prisms(tri, n, layers)
    if np.any(_inverted(points, tets, expected)):
        raise FecheckError("the extruded layer has inverted or flat tetrahedra: the thickness "
                           "is too large for the surface's curvature, or the surface folds "
                           "(extrusion_directions gives smoothed directions that may not)")
    flip = expected < 0
    tets[flip] = tets[flip][:, [0, 2, 1, 3]]
    bottom = tri[:, [0, 2, 1]] + layers * n
    return TetMesh(points, tets, {"top": tri.copy(), "bottom": bottom})


def extrusion_directions(surface: TriMesh, thickness_mm: float | np.ndarray, *,
                         layers: int = 4, ratio: float = 1.0,
                         max_rounds: int = 1024) -> tuple[np.ndarray, int]:
    """Extrusion directions for `extrude_layer` that invert no tetrahedron.

    The unit vertex normals are averaged over each vertex's 1-ring (uniform weights over
    its neighbours and itself) and renormalised, ``r`` times, for r in `ROUND_SCHEDULE`
    (0, 1, 2, 4, …, capped by `max_rounds`, which is tried last); the first r whose
    extrusion (``thickness_mm`` mm along the normal, `layers`, `ratio` as in
    `extrude_layer`) has only positive tetrahedra wins.

    Returns
    -------
    (n, 3) unit directions on the outward side (the sign of `TriMesh.vertex_normals`;
    the layer goes along minus these), exactly the vertex normals when r = 0; and r.

    Raises
    ------
    FecheckError
        when prisms stay inverted after `max_rounds` rounds.
    """
    if int(max_rounds) != max_rounds or max_rounds < 0:
        raise FecheckError(f"max_rounds must be a whole number >= 0, got {max_rounds}")
    n = surface.n_points
    h, normals = _thickness(surface, thickness_mm), _normals(surface)
    depth = level_fractions(layers, ratio)
    tets, expected = _prisms(surface.faces, n, layers)
    ring = _ring_average(surface.faces, n)
    d, done, bad = normals.copy(), 0, np.zeros(surface.n_faces, dtype=bool)
    for rounds in _schedule(int(max_rounds)):
        for _ in range(rounds - done):
            d = _normalised(ring @ d)
        done = rounds
        points = _levels(surface.points, _offsets(h, normals, d), depth)
        bad = _inverted(points, tets, expected).reshape(layers, -1, 3).any(axis=(0, 2))
        if not bad.any():
            return d, rounds
    where = surface.points[surface.faces[bad]].mean(axis=1)
    worst = densest(where)
    raise ExtrusionError(f"{int(bad.sum())} of {surface.n_faces} faces extrude into "
                         f"inverted prisms after {done} rounds of normal smoothing (e.g. "
                         f"the face at ({worst[0]:.1f}, {worst[1]:.1f}, {worst[2]:.1f}) mm): "
                         "use a thinner layer, or a smoother or finer surface", where)


def densest(points: np.ndarray, radius_mm: float = 2.0) -> np.ndarray:
    """(3,) the point of `points` (k, 3) with the most others within `radius_mm`: where a
    cluster of them is, mm."""
    from scipy.spatial import cKDTree

    counts = cKDTree(points).query_ball_point(points, radius_mm, return_length=True)
    return points[int(np.argmax(counts))]


class ExtrusionError(FecheckError):
    """A surface that no smoothing of its normals extrudes without inverted prisms;
    `where` (k, 3): the centroids of its faces that invert, mm."""

    def __init__(self, message: str, where: np.ndarray):
        super().__init__(message)
        self.where = where


def _schedule(max_rounds: int) -> list[int]:
    """The round counts to try: `ROUND_SCHEDULE` up to `max_rounds`, then `max_rounds`."""
    return sorted({r for r in ROUND_SCHEDULE if r <= max_rounds} | {max_rounds})


def _thickness(surface: TriMesh, thickness_mm: float | np.ndarray) -> np.ndarray:
    """(n,) layer thickness at every vertex, mm, checked finite and positive."""
    h = np.broadcast_to(np.asarray(thickness_mm, dtype=float), (surface.n_points,))
    if not np.all(np.isfinite(h)) or np.any(h <= 0):
        raise FecheckError("layer thickness must be finite and positive at every vertex (mm)")
    return h


def _normals(surface: TriMesh) -> np.ndarray:
    """(n, 3) unit vertex normals, checked present at every vertex."""
    normals = surface.vertex_normals
    if np.any(np.linalg.norm(normals, axis=1) < 0.5):
        raise FecheckError("the surface has vertices without a normal (unused or degenerate "
                           "faces only): clean the mesh before extruding it")
    return normals


def _unit(directions: np.ndarray, n: int) -> np.ndarray:
    """(n, 3) `directions` checked finite and non-zero, scaled to unit length."""
    d = np.asarray(directions, dtype=float)
    if d.shape != (n, 3) or not np.all(np.isfinite(d)):
        raise FecheckError(f"extrusion directions must be a finite ({n}, 3) array, one per "
                           f"surface vertex, got shape {d.shape}")
    norm = np.linalg.norm(d, axis=1, keepdims=True)
    if np.any(norm < 1e-12):
        raise FecheckError("extrusion directions must be non-zero at every vertex")
    return d / norm


def _normalised(v: np.ndarray) -> np.ndarray:
    """Rows of `v` scaled to unit length (zero rows stay zero)."""
    norm = np.linalg.norm(v, axis=1, keepdims=True)
    return np.divide(v, norm, out=np.zeros_like(v), where=norm > 0)


def _offsets(h: np.ndarray, normals: np.ndarray, directions: np.ndarray | None) -> np.ndarray:
    """(n, 3) outward vectors from each vertex's bottom copy to the vertex, mm: h_v n_v, or
    h_v d_v / max(d_v·n_v, `MIN_COSINE`) along given unit directions."""
    if directions is None:
        return h[:, None] * normals
    cosine = np.maximum(np.einsum("ij,ij->i", directions, normals), MIN_COSINE)
    return (h / cosine)[:, None] * directions


def _levels(pts: np.ndarray, offsets: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """((layers + 1)·n, 3) points of all levels, level k's copy of vertex v at k·n + v."""
    return (pts[None] - depth[:, None, None] * offsets[None]).reshape(-1, 3)


def _prisms(tri: np.ndarray, n: int, layers: int) -> tuple[np.ndarray, np.ndarray]:
    """(3·m·layers, 4) tetrahedra of the prisms, level-major then face then the three of a
    prism, and (3·m·layers,) the sign each one's volume must have."""
    abc = np.sort(tri, axis=1)
    corners = np.concatenate([abc, abc + n], axis=1)                  # (m, 6): top, below
    tets = np.concatenate([corners[:, _PRISM_TETS] + k * n for k in range(layers)])
    expected = np.tile(np.outer(_parity(tri), _SIGNS).ravel(), layers)
    return tets.reshape(-1, 4), expected


def _inverted(points: np.ndarray, tets: np.ndarray, expected: np.ndarray) -> np.ndarray:
    """(t,) True where a tetrahedron's volume does not have its `expected` sign (inverted,
    or flat)."""
    a, b, c, d = (points[tets[:, i]] for i in range(4))
    vol = np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a))
    return vol * expected <= 0.0


def _ring_average(tri: np.ndarray, n: int) -> sp.csr_matrix:
    """(n, n) sparse averaging over each vertex's 1-ring: uniform weights over the vertex
    and its edge neighbours."""
    edges = tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    rows = np.concatenate([edges[:, 0], edges[:, 1], np.arange(n)])
    cols = np.concatenate([edges[:, 1], edges[:, 0], np.arange(n)])
    adjacency = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    adjacency.data[:] = 1.0                       # an edge shared by two faces counts once
    return sp.diags(1.0 / np.asarray(adjacency.sum(axis=1)).ravel()) @ adjacency


def _parity(tri: np.ndarray) -> np.ndarray:
    """(m,) +1 where sorting a face's vertex indices is an even permutation (a rotation of
    the face, which keeps its orientation), -1 where it is odd (it reverses it)."""
    order = np.argsort(tri, axis=1)
    rotation = np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1]])
    even = (order[:, None, :] == rotation[None]).all(axis=2).any(axis=1)
    return np.where(even, 1.0, -1.0)
