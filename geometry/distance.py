"""Distances from points to a triangle mesh: along rays, and to the closest point.

Units: mm. Both are vectorised through compiled BVHs (Embree for rays, libigl's AABB for
closest points): no Python loop over points or faces.
"""

from __future__ import annotations

import numpy as np

from geometry.mesh import TriMesh


def ray_distance(origins: np.ndarray, directions: np.ndarray, target: TriMesh
                 ) -> np.ndarray:
    """Distance (mm) along each ray to its first hit on `target`; inf where it misses.

    Vectorised through Embree's BVH (trimesh's ``ray_pyembree``), no Python loop.
    """
    import trimesh
    from trimesh.ray.ray_pyembree import RayMeshIntersector

    mesh = trimesh.Trimesh(target.points, target.faces, process=False)
    hits, index_ray, _ = RayMeshIntersector(mesh).intersects_location(
        origins, directions, multiple_hits=False)
    out = np.full(len(origins), np.inf)
    out[index_ray] = np.linalg.norm(hits - origins[index_ray], axis=1)
    return out


def closest_distance(points: np.ndarray, target: TriMesh) -> tuple[np.ndarray, np.ndarray]:
    """Unsigned closest-point distance (mm) to `target` and the closest face index."""
    import igl

    tree = igl.AABB()
    tree.init(target.points, target.faces)
    sq, face, _ = tree.squared_distance(target.points, target.faces,
                                        np.ascontiguousarray(points, dtype=float))
    return np.sqrt(sq), np.asarray(face, dtype=np.int64)

