"""Spherical caps: an icosphere cut by a plane (thesis §5.2.2 hemispheres, Fig. 5.13).

The kept side is where (x - cut_point)·cut_normal <= 0: the normal points AWAY from the
kept cap. Faces crossing the plane are clipped exactly at it (new vertices on the
crossed edges, shared by both neighbouring faces), so the cut boundary lies on the
plane and the open cap is a disc (χ = 1). ``closed=True`` adds a flat fan of faces on
the plane (region ``"cut"``, normals along `cut_normal`), giving a closed solid (χ = 2).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from geometry.cache import cached_build
from geometry.errors import FecheckError
from geometry.icosphere import check_sphere_parameters, guard_subdivisions, icosphere
from geometry.mesh import TriMesh

#: Vertices closer than this fraction of the radius to the plane are moved onto it.
SNAP_RTOL = 1e-9


def clip_by_plane(mesh: TriMesh, point: np.ndarray, normal: np.ndarray,
                  snap: float = 0.0) -> TriMesh:
    """The part of `mesh` where (x - point)·normal <= 0, crossing faces cut at the plane.

    Vertices within `snap` mm of the plane are first projected onto it. Winding is kept.
    """
    n = normal / np.linalg.norm(normal)
    pts = mesh.points.copy()
    s = (pts - point) @ n
    near = np.abs(s) <= snap
    pts[near] -= s[near, None] * n
    s[near] = 0.0
    faces = mesh.faces
    inside = s[faces] <= 0
    n_in = inside.sum(axis=1)
    kept = [faces[n_in == 3]]

    # rotate crossing faces so that the lone vertex (outside for 2-in, inside for 1-in)
    # comes first, keeping the cyclic order and hence the winding
    cross = faces[(n_in == 1) | (n_in == 2)]
    lone_is_inside = (inside[(n_in == 1) | (n_in == 2)].sum(axis=1) == 1)
    flags = inside[(n_in == 1) | (n_in == 2)] == lone_is_inside[:, None]
    first = np.argmax(flags, axis=1)
    roll = (first[:, None] + np.arange(3)) % 3
    tri = np.take_along_axis(cross, roll, axis=1)

    edges = np.sort(np.vstack([tri[:, [0, 1]], tri[:, [0, 2]]]), axis=1)
    uniq, inv = np.unique(edges, axis=0, return_inverse=True)
    inv = inv.ravel()
    sa, sb = s[uniq[:, 0]], s[uniq[:, 1]]
    t = sa / (sa - sb)
    new_pts = pts[uniq[:, 0]] + t[:, None] * (pts[uniq[:, 1]] - pts[uniq[:, 0]])
    base = len(pts)
    k = len(tri)
    p01, p02 = base + inv[:k], base + inv[k:]
    one = lone_is_inside
    kept.append(np.column_stack([tri[one, 0], p01[one], p02[one]]))
    two = ~one
    kept.append(np.column_stack([p01[two], tri[two, 1], tri[two, 2]]))
    kept.append(np.column_stack([p01[two], tri[two, 2], p02[two]]))
    all_pts = np.vstack([pts, new_pts])
    out = np.vstack(kept)
    c = all_pts[out]
    area2 = np.linalg.norm(np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]), axis=1)
    out = out[area2 > 1e-12 * max(area2.max(initial=0.0), 1e-300)]
    return _compact(all_pts, out)


def _compact(points: np.ndarray, faces: np.ndarray, regions: dict | None = None) -> TriMesh:
    keys = np.round(points, 12) + 0.0
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    faces = inverse.ravel()[faces]
    used, remap = np.unique(faces, return_inverse=True)
    return TriMesh(points[first][used], remap.reshape(-1, 3), regions or {})


def close_planar_boundary(mesh: TriMesh, normal: np.ndarray) -> TriMesh:
    """Close a planar boundary loop with a fan from its centroid (region ``"cut"``).

    Each fan face traverses its boundary edge opposite to the open mesh, so winding stays
    consistent; the loop must be convex (true for a plane cutting a sphere).
    """
    f = mesh.faces
    directed = f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    _, inverse, counts = np.unique(np.sort(directed, axis=1), axis=0, return_inverse=True,
                                   return_counts=True)
    boundary = directed[counts[inverse.ravel()] == 1]
    if len(boundary) == 0:
        return mesh
    centre = mesh.points[np.unique(boundary)].mean(axis=0)
    ci = mesh.n_points
    fan = np.column_stack([boundary[:, 1], boundary[:, 0], np.full(len(boundary), ci)])
    faces = np.vstack([f, fan])
    regions = {"surface": np.arange(len(f)), "cut": np.arange(len(f), len(faces))}
    return TriMesh(np.vstack([mesh.points, centre]), faces, regions)


def spherical_cap(radius: float, subdivisions: int, center: Sequence[float] = (0.0, 0.0, 0.0),
                  *, cut_point: Sequence[float], cut_normal: Sequence[float],
                  closed: bool = False, method: str = "gmsh", cache: bool = True) -> TriMesh:
    """The part of an icosphere with (x - cut_point)·cut_normal <= 0, cut exactly (mm).

    Parameters
    ----------
    radius, subdivisions, center, method : the icosphere (see `geometry.icosphere`)
    cut_point : a point of the cutting plane, mm
    cut_normal : the plane normal, pointing away from the kept part
    closed : add a flat cap on the plane (region ``"cut"``); the sphere part is region
        ``"surface"``

    >>> hemi = spherical_cap(10.0, 3, cut_point=(0, 0, 0), cut_normal=(0, 0, 1), cache=False)
    >>> bool(hemi.points[:, 2].max() <= 1e-9)
    True
    """
    check_sphere_parameters(radius, subdivisions, center, method)
    guard_subdivisions("spherical_cap", subdivisions)
    cp = np.asarray(cut_point, dtype=float)
    cn = np.asarray(cut_normal, dtype=float)
    if cp.shape != (3,) or cn.shape != (3,) or not np.all(np.isfinite(np.r_[cp, cn])):
        raise FecheckError("cut_point and cut_normal must be 3 finite numbers each")
    if np.linalg.norm(cn) == 0:
        raise FecheckError("cut_normal must be a non-zero vector")
    cn = cn / np.linalg.norm(cn)
    distance = (np.asarray(center, dtype=float) - cp) @ cn
    if distance >= radius:
        raise FecheckError("the cutting plane leaves nothing of the sphere: move cut_point "
                           "or flip cut_normal (the kept side is where the normal points away)")

    def build() -> TriMesh:
        sphere = icosphere(radius, subdivisions, center, method=method, cache=cache)
        cap = clip_by_plane(sphere, cp, cn, snap=SNAP_RTOL * radius)
        if closed and distance > -radius:
            return close_planar_boundary(cap, cn)
        return TriMesh(cap.points, cap.faces, {"surface": np.arange(cap.n_faces)})

    params = {"radius": radius, "subdivisions": subdivisions, "center": list(center),
              "cut_point": cp, "cut_normal": cn, "closed": closed, "method": method}
    return cached_build("spherical-cap", params, build, use_cache=cache)
