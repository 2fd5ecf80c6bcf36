"""Mesh sanity checks of thesis Table 3.1 and a few more, vectorised.

`mesh_report` answers: how many faces, vertices and edges; the Euler number
χ = V - E + F; whether the winding is consistent, the surface convex, watertight or
empty; area, enclosed volume, edge lengths; degenerate and duplicate faces; connected
components and boundary edges.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from geometry.mesh import TetMesh, TriMesh, edge_table

#: Relative tolerance on |V_hull - V_mesh| / V_hull for a closed mesh to count as convex.
CONVEX_RTOL = 1e-9
#: A face is degenerate when its area is below this fraction of the mean face area.
DEGENERATE_RTOL = 1e-12


@dataclass(frozen=True)
class MeshReport:
    """Properties of one triangle mesh (lengths mm, areas mm², volumes mm³)."""

    name: str
    faces: int
    vertices: int
    edges: int
    euler: int
    winding_consistent: bool
    convex: bool
    watertight: bool
    empty: bool
    area_mm2: float
    volume_mm3: float | None
    edge_min_mm: float
    edge_mean_mm: float
    edge_max_mm: float
    degenerate_faces: int
    duplicate_faces: int
    components: int
    boundary_edges: int

    def as_dict(self) -> dict:
        """Plain JSON-ready dictionary of every field."""
        return asdict(self)


def _edge_table(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unique undirected edges (e, 2), faces per edge (e,), signed direction sum (e,)."""
    table = edge_table(faces)
    return table.edges, table.counts, table.direction_sum


def edge_counts(faces: np.ndarray) -> tuple[int, int, int]:
    """Boundary edges (one face), non-manifold edges (3+ faces) and edges that two of
    their faces run the same way (opposite windings; every non-manifold edge has such a
    pair)."""
    _, counts, direction_sum = _edge_table(faces)
    opposed = ((counts == 2) & (direction_sum != 0)) | (counts > 2)
    return (int(np.count_nonzero(counts == 1)), int(np.count_nonzero(counts > 2)),
            int(np.count_nonzero(opposed)))


def non_manifold_faces(mesh: TriMesh) -> np.ndarray:
    """Indices of the faces on an edge that three or more faces share (non-manifold)."""
    table = mesh.edge_table
    bad = table.counts[table.sorted_edge] > 2
    return np.unique(table.order[bad] // 3)


def _components(n_points: int, faces: np.ndarray, edges: np.ndarray) -> int:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])),
                       shape=(n_points, n_points))
    _, labels = connected_components(graph, directed=False)
    return len(np.unique(labels[np.unique(faces)]))


def _is_convex(mesh: TriMesh, closed: bool, volume: float | None) -> bool:
    if not closed or volume is None or volume <= 0:
        return False
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(mesh.points[np.unique(mesh.faces)])
    except QhullError:
        return False
    return abs(hull.volume - volume) <= CONVEX_RTOL * hull.volume


def mesh_report(mesh: TriMesh, name: str = "") -> MeshReport:
    """Check `mesh` (thesis Table 3.1 and more).

    Definitions: V counts the vertices used by faces; χ = V - E + F (2 for a closed
    genus-0 surface, 1 for a disc); winding consistent = every edge shared by two faces
    is traversed in opposite directions by them (and no edge by more than two faces);
    watertight = every edge is shared by exactly two faces; convex = closed, outward,
    and its volume equals its convex hull's within `CONVEX_RTOL`; volume is the signed
    divergence-theorem volume (closed meshes only, else None; negative means inward
    normals).

    >>> from geometry.icosphere import icosphere
    >>> r = mesh_report(icosphere(10.0, 1, cache=False))
    >>> (r.euler, r.watertight, r.convex)
    (2, True, True)
    """
    faces = mesh.faces
    if len(faces) == 0:
        return MeshReport(name, 0, mesh.n_points, 0, mesh.n_points, True, False, False, True,
                          0.0, None, 0.0, 0.0, 0.0, 0, 0, 0, 0)
    edges, counts, direction_sum = _edge_table(faces)
    n_used = len(np.unique(faces))
    watertight = bool(np.all(counts == 2))
    consistent = bool(np.all(counts <= 2) and np.all(direction_sum[counts == 2] == 0))
    volume = mesh.signed_volume if watertight and consistent else None
    lengths = np.linalg.norm(mesh.points[edges[:, 0]] - mesh.points[edges[:, 1]], axis=1)
    areas = mesh.face_areas
    duplicate = len(faces) - len(np.unique(np.sort(faces, axis=1), axis=0))
    return MeshReport(
        name=name,
        faces=len(faces),
        vertices=n_used,
        edges=len(edges),
        euler=n_used - len(edges) + len(faces),
        winding_consistent=consistent,
        convex=_is_convex(mesh, watertight and consistent, volume),
        watertight=watertight,
        empty=False,
        area_mm2=float(areas.sum()),
        volume_mm3=volume,
        edge_min_mm=float(lengths.min()),
        edge_mean_mm=float(lengths.mean()),
        edge_max_mm=float(lengths.max()),
        degenerate_faces=int(np.count_nonzero(areas < DEGENERATE_RTOL * areas.mean())),
        duplicate_faces=int(duplicate),
        components=_components(mesh.n_points, faces, edges),
        boundary_edges=int(np.count_nonzero(counts == 1)),
    )


def tet_surface(mesh: TetMesh) -> TriMesh:
    """Boundary triangles of a tetrahedral mesh (faces used by one tet), outward for
    positively oriented tets; quadratic tets contribute their corner nodes."""
    t = mesh.tets[:, :4]
    faces = np.vstack([t[:, [1, 2, 3]], t[:, [0, 3, 2]], t[:, [0, 1, 3]], t[:, [0, 2, 1]]])
    _, inverse, counts = np.unique(np.sort(faces, axis=1), axis=0, return_inverse=True,
                                   return_counts=True)
    return TriMesh(mesh.points, faces[counts[inverse.ravel()] == 1])
