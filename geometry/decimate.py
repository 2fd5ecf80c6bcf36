"""Mesh decimation by quadric edge collapse (libigl ``qslim``) with a repair of fold-overs.

``igl.qslim`` collapses edges in order of the Garland-Heckbert quadric error and places each
merged vertex where that error is least. Open borders are kept: libigl joins the border to a
phony vertex at infinity, so a border vertex cannot leave the border's line. Every collapse
keeps the winding, but not always the facing: where the sheet is nearly flat the quadric
hardly constrains a vertex within the plane, and some collapses fold a face over its
neighbour (normal reversed, yet within 0.01 mm of the old surface). `unfold` repairs these:
folded faces with two border edges (ears on a concave border, which no vertex position can
unfold) are dropped, and the other folded faces' vertices are moved to the mean of their
neighbours (border vertices: of their border neighbours), put back on the old surface
(border) by closest point, for up to `UNFOLD_ROUNDS` rounds. Over 19 targets from 5 % to
95 % of the faces of each scanned cartilage sheet (medial and lateral tibial, femoral), qslim
folded up to 7, 4 and 20 faces at 46 of the 57 targets (none on icospheres or meshed discs);
1 to 3 rounds unfolded them all, and at most one ear was dropped.

Measured on the scanned medial tibial cartilage sheet
(``lenhart2015_R_tibia_cartilage_medial.stl``, 4,244 faces, edges about 1 mm) halved to
2,122 faces, distances by ``igl.point_mesh_squared_distance``, times the fastest of 15 runs
on a shared, loaded 2-core machine (vertex clustering, which this module used before, for
comparison):

=====================================  ================  =================
                                       qslim + unfold    vertex clustering
=====================================  ================  =================
faces                                  2,122             1,933
new vertices to old surface, mean/max  0.0012/0.011 mm   0.0007/0.055 mm
old vertices to new surface, mean/max  0.0021/0.071 mm   0.024/0.58 mm
area change                            -0.004 %          -2.05 %
border length change                   -0.005 %          +7.4 %
border vertices old to new, max        0.012 mm          0.58 mm
time (qslim alone: 25 ms)              42 ms             18 ms
=====================================  ================  =================

qslim alone folds 7 faces here and gives 0.0019/0.014 mm old to new and +0.08 % area (the
folded faces counted twice); the repair moves the 0.014 mm maximum to 0.071 mm at the few
moved vertices. The whole two-sheet tibial cartilage (8,602 to 4,301 faces): 0.0012/0.014 mm
new to old, 0.0021/0.071 mm old to new, -0.004 % area (clustering: 3,913 faces,
0.021/0.68 mm old to new, -1.74 %).

>>> from geometry.icosphere import icosphere
>>> m = decimate(icosphere(10.0, 4, method="trimesh", cache=False), 1000)
>>> m.n_faces
1000
>>> bool(np.abs(np.linalg.norm(m.points, axis=1) - 10.0).max() < 0.05)
True
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from geometry.errors import FecheckError
from geometry.mesh import TriMesh

if TYPE_CHECKING:
    import scipy.sparse as sp

#: Smallest target: a closed surface cannot have fewer than 4 faces.
MIN_FACES = 4
#: Rounds of `unfold` before a remaining fold-over is an error.
UNFOLD_ROUNDS = 10
#: Decimated meshes `decimated` keeps in this process (the oldest is dropped first).
KEPT = 16
_kept: dict[tuple[str, int], TriMesh] = {}


def decimated(mesh: TriMesh, target_faces: int) -> TriMesh:
    """`decimate`, kept in this process by the mesh's content and the target: a scene's
    surfaces are decimated once, not once per run (a scanned run decimates its femoral
    sheet for the master and again for each compartment's thickness). The mesh returned
    is shared by every caller: its arrays are read-only."""
    from geometry.cache import content_digest

    key = (content_digest([mesh]), int(target_faces))
    if key not in _kept:
        if len(_kept) >= KEPT:
            del _kept[next(iter(_kept))]
        kept = decimate(mesh, target_faces)
        for array in (kept.points, kept.faces, *kept.regions.values()):
            array.flags.writeable = False
        _kept[key] = kept
    return _kept[key]


def decimate(mesh: TriMesh, target_faces: int) -> TriMesh:
    """`mesh` reduced to at most `target_faces` faces by quadric edge collapse.

    Parameters
    ----------
    mesh : edge-manifold triangle mesh, closed or open (mm); its regions are not kept;
        pinched vertices are split first (`split_pinched`)
    target_faces : wanted face count, at least `MIN_FACES`; the result has that many or a
        few fewer (a collapse removes two faces, one on a border; `unfold` may drop an ear)

    Returns
    -------
    A new TriMesh with the winding and the facing of `mesh` (every face's normal agrees
    with the face it came from), or `mesh` itself when it has no more than `target_faces`
    faces.

    Raises
    ------
    FecheckError
        for an empty mesh, non-finite points, a target that is not an integer of at least
        `MIN_FACES`, a mesh with an edge shared by more than two faces, or when the target
        cannot be reached (e.g. several closed components of 4 faces each) or qslim
        returns no faces.
    """
    import igl

    _check(mesh, target_faces)
    if mesh.n_faces <= target_faces:
        return mesh
    source = split_pinched(mesh)
    points, faces, birth, _ = igl.qslim(source.points, source.faces, int(target_faces))
    if len(faces) == 0:
        raise FecheckError(f"decimation of a mesh of {mesh.n_faces} faces to {target_faces} "
                           "returned no faces (libigl qslim failed); give "
                           "scanned.decimate_faces = 0 (the full mesh) or clean the mesh")
    if len(faces) > target_faces:
        raise FecheckError(f"decimation stopped at {len(faces)} faces, above the target "
                           f"{target_faces}: ask for more faces")
    points, faces = unfold(source, points, faces, source.face_cross[birth])
    used, remap = np.unique(faces, return_inverse=True)
    return TriMesh(points[used], remap.reshape(faces.shape))


def split_pinched(mesh: TriMesh) -> TriMesh:
    """`mesh` with each pinched vertex (where faces meet only at that vertex, as on a
    voxel-stair sheet's corners: not vertex-manifold) split into one copy per fan of faces
    around it; `mesh` itself when it has none. ``igl.qslim`` returns no faces at all for a
    mesh with a pinched vertex."""
    import igl

    used = np.zeros(mesh.n_points, dtype=bool)
    used[mesh.faces.ravel()] = True
    if igl.is_vertex_manifold(mesh.faces)[used].all():
        return mesh
    faces, source = igl.split_nonmanifold(mesh.faces)
    return TriMesh(mesh.points[source], faces)


def _check(mesh: TriMesh, target_faces: int) -> None:
    """Raise FecheckError unless `mesh` and `target_faces` can be decimated."""
    import igl

    if isinstance(target_faces, bool) or not isinstance(target_faces, (int, np.integer)):
        raise FecheckError(f"target_faces must be an integer, got {target_faces!r}")
    if target_faces < MIN_FACES:
        raise FecheckError(f"target_faces must be at least {MIN_FACES}, got {target_faces}")
    if mesh.n_faces == 0:
        raise FecheckError("cannot decimate an empty mesh (no faces)")
    if not np.all(np.isfinite(mesh.points)):
        raise FecheckError("cannot decimate a mesh with NaN or infinite coordinates")
    manifold = igl.is_edge_manifold(mesh.faces)[-1]
    if not manifold.all():
        raise FecheckError(f"cannot decimate a mesh with {np.count_nonzero(~manifold)} edges "
                           "shared by more than two faces (not edge-manifold)")


def folded(points: np.ndarray, faces: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(m,) True where a face's normal does not point to the side of `reference` (m, 3)."""
    t = points[faces]
    cross = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    return np.einsum("ij,ij->i", cross, reference) <= 0


def unfold(mesh: TriMesh, points: np.ndarray, faces: np.ndarray,
           reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points and faces of a decimated `mesh` with no face folded against `reference`.

    Parameters
    ----------
    mesh : the mesh before decimation (its surface and border receive moved vertices)
    points : (n, 3) decimated vertices, mm
    faces : (m, 3) decimated faces
    reference : (m, 3) normal of the old face each new face came from

    Each round drops folded ears (faces with two border edges) and moves the vertices of
    the other folded faces to the mean of their neighbours, projected back onto `mesh`.
    """
    import igl

    points = points.copy()
    old_border = igl.boundary_facets(mesh.faces)[0]
    for _ in range(UNFOLD_ROUNDS):
        bad = folded(points, faces, reference)
        if not bad.any():
            return points, faces
        face_of_edge = igl.boundary_facets(faces)[1]
        ear = bad & (np.bincount(face_of_edge, minlength=len(faces)) >= 2)
        faces, reference, bad = faces[~ear], reference[~ear], bad[~ear]
        border = igl.boundary_facets(faces)[0]
        moved = np.unique(faces[bad])
        target = _neighbour_mean(points, faces, border, moved)
        on_border = np.isin(moved, border)
        points[moved[~on_border]] = _closest(target[~on_border], mesh.points, mesh.faces)
        points[moved[on_border]] = _closest(target[on_border], mesh.points, old_border)
    count = np.count_nonzero(folded(points, faces, reference))
    if count:
        raise FecheckError(f"decimation folded {count} faces over their neighbours that "
                           f"{UNFOLD_ROUNDS} repair rounds could not unfold; try another "
                           "target_faces")
    return points, faces


def _neighbour_mean(points: np.ndarray, faces: np.ndarray, border: np.ndarray,
                    moved: np.ndarray) -> np.ndarray:
    """(k, 3) mean of the neighbours of the vertices `moved`, mm: of those along the border
    (edges `border`) for a border vertex, of those along any face edge for the others."""
    import scipy.sparse as sp

    n = len(points)
    on_border = np.zeros(n)
    on_border[border.ravel()] = 1.0
    edges = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    weights = (sp.diags(1.0 - on_border) @ _adjacency(n, edges)
               + sp.diags(on_border) @ _adjacency(n, border)).tocsr()[moved]
    return (weights @ points) / np.asarray(weights.sum(axis=1))


def _adjacency(n: int, edges: np.ndarray) -> sp.csr_matrix:
    """(n, n) symmetric 0/1 vertex adjacency of the (e, 2) `edges`."""
    import scipy.sparse as sp

    a = sp.coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    return ((a + a.T) > 0).astype(float).tocsr()


def _closest(query: np.ndarray, points: np.ndarray, simplices: np.ndarray) -> np.ndarray:
    """(k, 3) closest points to `query` on the triangles or segments `simplices`, mm."""
    import igl

    if len(query) == 0:
        return query
    return igl.point_mesh_squared_distance(query, points, simplices)[2]
