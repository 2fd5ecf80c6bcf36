"""Distances from points to a triangle mesh: along rays, to the closest point, to the
nearest vertex; and the gap from points to a sphere.

Units: mm. The mesh distances are vectorised through compiled trees (Embree's BVH for
rays, libigl's AABB for closest points, a k-d tree over the vertices): no Python loop over
points or faces.
"""

from __future__ import annotations

import numpy as np

from geometry.mesh import TriMesh


def ray_hits(origins: np.ndarray, directions: np.ndarray, target: TriMesh,
             facing: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Distance (mm) along each unit ray to its nearest hit on `target` and the face hit
    (-1 and inf where it misses). With `facing` (n, 3), only faces whose normal has a
    positive component along the ray's `facing` vector count (e.g. only faces seen from
    their outside)."""
    origins = np.ascontiguousarray(origins, dtype=float)
    hits, index_ray, index_tri = target.ray_intersector.intersects_location(
        origins, directions, multiple_hits=facing is not None)
    dist = np.linalg.norm(hits - origins[index_ray], axis=1)
    if facing is not None:
        ok = np.einsum("ij,ij->i", target.face_normals[index_tri], facing[index_ray]) > 0.0
        index_ray, index_tri, dist = index_ray[ok], index_tri[ok], dist[ok]
    order = np.lexsort((dist, index_ray))
    first = order[np.r_[True, np.diff(index_ray[order]) != 0]] if len(order) else order
    out = np.full(len(origins), np.inf)
    face = np.full(len(origins), -1, dtype=np.int64)
    out[index_ray[first]] = dist[first]
    face[index_ray[first]] = index_tri[first]
    return out, face


def closest_distance(points: np.ndarray, target: TriMesh) -> tuple[np.ndarray, np.ndarray]:
    """Unsigned closest-point distance (mm) to `target` and the closest face index."""
    import igl

    tree = igl.AABB()
    tree.init(target.points, target.faces)
    sq, face, _ = tree.squared_distance(target.points, target.faces,
                                        np.ascontiguousarray(points, dtype=float))
    return np.sqrt(sq), np.asarray(face, dtype=np.int64)



def sphere_gap_mm(points: np.ndarray, center: np.ndarray, radius: float) -> float:
    """Smallest distance (mm, ≥ 0) from `points` (n, 3) to the sphere's surface seen from
    outside: 0 when a point lies in the sphere."""
    d = np.linalg.norm(points - center, axis=1) - radius
    return max(float(d.min()), 0.0)


def vertex_gap_mm(points: np.ndarray, mesh: TriMesh, settle_mm: float) -> float:
    """Smallest distance (mm) from `points` (n, 3) to the vertices of `mesh` (within an
    edge length of its surface). Every k-th point against every k-th vertex first (about
    2,000 of each): that upper bound is returned when it is within `settle_mm` (the usual,
    touching case, settled fast), else the exact nearest-vertex distance."""
    from scipy.spatial import cKDTree

    k = max(1, len(mesh.points) // 2000, len(points) // 2000)
    near = float(cKDTree(mesh.points[::k]).query(points[::k], k=1)[0].min())
    if near <= settle_mm:
        return near
    return float(cKDTree(mesh.points).query(points, k=1)[0].min())
