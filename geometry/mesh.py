"""Plain mesh containers: NumPy arrays with a few cached derived properties.

Units are mm. Builders in this package return these; `geometry.io` reads and writes
them through meshio.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from geometry.errors import FecheckError


@dataclass(frozen=True, eq=False)
class EdgeTable:
    """The edges of a triangle mesh: its 3·m half-edges sorted by undirected edge.

    Half-edge 3k + j of face k runs from its corner j to corner j + 1 (mod 3).
    directed : (3m, 2) the half-edges;  order : (3m,) their indices sorted by undirected
    edge (stable);  start : (e,) where each edge's run begins in `order`
    edges : (e, 2) the unique undirected edges as sorted vertex pairs, in lexicographic
    order;  counts : (e,) faces sharing each;  direction_sum : (e,) Σ ±1 over those
    faces (+1 where the face runs from the lower vertex to the higher): 0 for an edge
    that two faces traverse in opposite directions
    """

    directed: np.ndarray
    order: np.ndarray
    start: np.ndarray
    edges: np.ndarray
    counts: np.ndarray
    direction_sum: np.ndarray

    @cached_property
    def sorted_edge(self) -> np.ndarray:
        """(3m,) the edge of every half-edge, in `order`."""
        return np.repeat(np.arange(len(self.edges)), self.counts)


def edge_table(faces: np.ndarray) -> EdgeTable:
    """The `EdgeTable` of triangles `faces` (m, 3) (one sort of integer edge keys)."""
    directed = np.asarray(faces, dtype=np.int64)[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    lo, hi = directed.min(axis=1), directed.max(axis=1)
    n = int(hi.max(initial=-1)) + 1
    key = lo * n + hi
    order = np.argsort(key, kind="stable")
    ordered = key[order]
    start = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]]) if len(key) else \
        np.zeros(0, dtype=np.int64)
    counts = np.diff(np.r_[start, len(key)])
    unique = ordered[start]
    sign = np.where(directed[:, 0] < directed[:, 1], 1, -1)[order]
    direction_sum = np.add.reduceat(sign, start) if len(key) else np.zeros(0, dtype=np.int64)
    return EdgeTable(directed, order, start, np.column_stack([unique // n, unique % n]),
                     counts, direction_sum)


@dataclass(frozen=True, eq=False)
class TriMesh:
    """A triangle surface mesh.

    Parameters
    ----------
    points : (n, 3) float array, mm
    faces : (m, 3) int array of vertex indices, counter-clockwise seen from outside
    regions : named subsets of faces, e.g. ``{"top": array([...])}``

    Examples
    --------
    >>> import numpy as np
    >>> m = TriMesh(np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    >>> float(m.area)
    0.5
    """

    points: np.ndarray
    faces: np.ndarray
    regions: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        points = np.ascontiguousarray(self.points, dtype=np.float64)
        faces = np.ascontiguousarray(self.faces, dtype=np.int64)
        if points.ndim != 2 or points.shape[1] != 3:
            raise FecheckError(f"mesh points must be an (n, 3) array, got shape {points.shape}")
        if faces.ndim != 2 or faces.shape[1] != 3:
            raise FecheckError(f"mesh faces must be an (m, 3) array, got shape {faces.shape}")
        if faces.size and (faces.min() < 0 or faces.max() >= len(points)):
            raise FecheckError("mesh faces refer to vertices that do not exist")
        if not np.all(np.isfinite(points)):
            raise FecheckError("mesh points contain NaN or infinite coordinates")
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "faces", faces)

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    @property
    def n_points(self) -> int:
        return len(self.points)

    @cached_property
    def triangles(self) -> np.ndarray:
        """(m, 3, 3) vertex coordinates of every face, mm."""
        return self.points[self.faces]

    @cached_property
    def face_cross(self) -> np.ndarray:
        """(m, 3) un-normalised face normals (twice the area vector), mm²."""
        t = self.triangles
        return np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])

    @cached_property
    def face_areas(self) -> np.ndarray:
        """(m,) face areas, mm²."""
        return 0.5 * np.linalg.norm(self.face_cross, axis=1)

    @cached_property
    def face_normals(self) -> np.ndarray:
        """(m, 3) unit face normals (zero for degenerate faces)."""
        c = self.face_cross
        n = np.linalg.norm(c, axis=1, keepdims=True)
        return np.divide(c, n, out=np.zeros_like(c), where=n > 0)

    @cached_property
    def face_centroids(self) -> np.ndarray:
        """(m, 3) face centroids, mm."""
        return self.triangles.mean(axis=1)

    @cached_property
    def area(self) -> float:
        """Total surface area, mm²."""
        return float(self.face_areas.sum())

    @cached_property
    def signed_volume(self) -> float:
        """Enclosed volume by the divergence theorem, mm³ (meaningful for closed meshes)."""
        t = self.triangles
        return float(np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum() / 6.0)

    @cached_property
    def edge_table(self) -> EdgeTable:
        """The mesh's `EdgeTable` (half-edges, unique edges, faces per edge, winding)."""
        return edge_table(self.faces)

    @cached_property
    def edges_unique(self) -> np.ndarray:
        """(e, 2) sorted vertex pairs of the unique edges."""
        return self.edge_table.edges

    @cached_property
    def vertex_normals(self) -> np.ndarray:
        """(n, 3) area-weighted unit vertex normals."""
        acc = np.zeros_like(self.points)
        for k in range(3):
            np.add.at(acc, self.faces[:, k], self.face_cross)
        n = np.linalg.norm(acc, axis=1, keepdims=True)
        return np.divide(acc, n, out=np.zeros_like(acc), where=n > 0)

    @cached_property
    def ray_intersector(self):
        """Embree ray queries on this mesh (trimesh's ``RayMeshIntersector``), built once."""
        import trimesh
        from trimesh.ray.ray_pyembree import RayMeshIntersector

        return RayMeshIntersector(trimesh.Trimesh(self.points, self.faces, process=False))

    def transformed(self, rotation: np.ndarray, translation: np.ndarray) -> TriMesh:
        """This mesh moved rigidly: x' = R x + t (mm)."""
        return TriMesh(self.points @ np.asarray(rotation).T + translation, self.faces, self.regions)


@dataclass(frozen=True, eq=False)
class TetMesh:
    """A tetrahedral volume mesh.

    Parameters
    ----------
    points : (n, 3) float array, mm
    tets : (m, 4) int array, positively oriented
    boundaries : named boundary triangle sets, e.g. ``{"top": (k, 3), "bottom": (j, 3)}``
    """

    points: np.ndarray
    tets: np.ndarray
    boundaries: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "points", np.ascontiguousarray(self.points, dtype=np.float64))
        object.__setattr__(self, "tets", np.ascontiguousarray(self.tets, dtype=np.int64))

    @cached_property
    def tet_volumes(self) -> np.ndarray:
        """(m,) signed tetrahedron volumes, mm³."""
        p = self.points[self.tets]
        return np.einsum("ij,ij->i", p[:, 1] - p[:, 0],
                         np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0])) / 6.0

    @cached_property
    def volume(self) -> float:
        """Total volume, mm³."""
        return float(np.abs(self.tet_volumes).sum())


def is_closed(mesh: TriMesh) -> bool:
    """True if every edge is shared by exactly two faces."""
    e = np.sort(mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1).astype(np.int64)
    _, counts = np.unique(e[:, 0] * mesh.n_points + e[:, 1], return_counts=True)
    return bool(np.all(counts == 2))


def components(mesh: TriMesh) -> list[np.ndarray]:
    """Face indices of each connected component (faces sharing a vertex), largest first."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    f = mesh.faces
    n = mesh.n_faces
    graph = sp.csr_matrix((np.ones(3 * n), (np.repeat(np.arange(n), 3), f.ravel())),
                          shape=(n, mesh.n_points))
    count, labels = connected_components(sp.bmat([[None, graph], [graph.T, None]]),
                                         directed=False)
    faces = labels[:n]
    groups = [np.flatnonzero(faces == k) for k in np.unique(faces)]
    return sorted(groups, key=len, reverse=True)


def submesh(mesh: TriMesh, faces: np.ndarray) -> TriMesh:
    """The faces `faces` of `mesh` with only the vertices they use."""
    used, inverse = np.unique(mesh.faces[faces], return_inverse=True)
    return TriMesh(mesh.points[used], inverse.reshape(-1, 3))
