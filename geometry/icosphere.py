"""Icospheres: subdivided icosahedra with every vertex on the sphere (thesis §3.1.2).

A level-n icosphere has exactly 20·4^n triangles, 10·4^n + 2 vertices and outward
(counter-clockwise seen from outside) winding. Two builders are offered: Gmsh (the
icosahedron as a discrete surface, `gmsh.model.mesh.refine` once per level, nodes
projected back onto the sphere after each level) and trimesh's `creation.icosphere`,
which the thesis compared in Table 3.1 and Fig. 3.3.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from geometry import budget
from geometry.cache import cached_build
from geometry.errors import FecheckError
from geometry.mesh import TriMesh

METHODS = ("gmsh", "trimesh")
MAX_SUBDIVISIONS = 8


def icosahedron() -> tuple[np.ndarray, np.ndarray]:
    """Unit icosahedron: (12, 3) vertices on the unit sphere, (20, 3) outward faces."""
    t = (1.0 + np.sqrt(5.0)) / 2.0
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0],
                  [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                  [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], dtype=float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
                  [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
                  [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
                  [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    return v / np.linalg.norm(v, axis=1, keepdims=True), f


def check_sphere_parameters(radius: float, subdivisions: int, center: Sequence[float],
                            method: str) -> None:
    """Raise FecheckError unless the icosphere parameters are valid (see `icosphere`)."""
    if not np.isfinite(radius) or radius <= 0:
        raise FecheckError(f"icosphere radius must be a positive number of mm, got {radius}")
    if int(subdivisions) != subdivisions or not 0 <= subdivisions <= MAX_SUBDIVISIONS:
        raise FecheckError(f"icosphere subdivisions must be an integer from 0 to "
                           f"{MAX_SUBDIVISIONS} (20·4^n faces), got {subdivisions}")
    c = np.asarray(center, dtype=float)
    if c.shape != (3,) or not np.all(np.isfinite(c)):
        raise FecheckError(f"icosphere center must be 3 finite coordinates in mm, got {center}")
    if method not in METHODS:
        raise FecheckError(f"icosphere method must be one of {METHODS}, got {method!r}")


def guard_subdivisions(builder: str, subdivisions: int) -> None:
    """`geometry.budget.guard` of a level-n icosphere (20·4^n triangles, exactly)."""
    budget.guard(builder, "subdivisions", int(subdivisions), budget.icosphere_estimate,
                 unit="", level=True)


def _unit_gmsh(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    from geometry.gmsh_session import gmsh_session, surface_triangles

    points, faces = icosahedron()
    for _ in range(subdivisions):
        with gmsh_session("icosphere") as gmsh:
            surf = gmsh.model.addDiscreteEntity(2)
            gmsh.model.mesh.addNodes(2, surf, np.arange(1, len(points) + 1), points.ravel())
            gmsh.model.mesh.addElementsByType(surf, 2, [], (faces + 1).ravel())
            gmsh.model.mesh.refine()
            points, faces = surface_triangles(gmsh, 2, surf)
        points = points / np.linalg.norm(points, axis=1, keepdims=True)
    return points, faces


def _unit_trimesh(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    return np.asarray(m.vertices), np.asarray(m.faces)


def icosphere(radius: float, subdivisions: int, center: Sequence[float] = (0.0, 0.0, 0.0), *,
              method: str = "gmsh", cache: bool = True) -> TriMesh:
    """A sphere of `radius` mm about `center` (mm) as a level-`subdivisions` icosphere.

    Parameters
    ----------
    radius : sphere radius, mm (> 0)
    subdivisions : n in 0..8; the mesh has 20·4^n faces, every vertex at distance
        `radius` from `center`
    center : sphere centre, mm
    method : ``"gmsh"`` (Gmsh refinement of the icosahedron) or ``"trimesh"``
    cache : reuse an identical earlier build from the on-disk cache

    Examples
    --------
    >>> m = icosphere(25.5, 2, cache=False)
    >>> m.n_faces
    320
    """
    check_sphere_parameters(radius, subdivisions, center, method)
    guard_subdivisions("icosphere", subdivisions)
    builder = _unit_gmsh if method == "gmsh" else _unit_trimesh
    unit = cached_build(f"icosphere-unit-{method}", {"subdivisions": int(subdivisions)},
                        lambda: TriMesh(*builder(int(subdivisions))), use_cache=cache)
    points = unit.points * float(radius) + np.asarray(center, dtype=float)
    return TriMesh(points, unit.faces)


def icosphere_volume_error(radius: float, subdivisions: int, method: str = "gmsh") -> float:
    """Relative volume error (V_mesh - V_sphere) / V_sphere of an icosphere (thesis Fig. 3.3).

    Negative: an inscribed polyhedron holds less than the sphere. Its magnitude falls
    like h² ∝ 4^-n, a factor ≈ 4 per level.
    """
    mesh = icosphere(radius, subdivisions, method=method)
    exact = 4.0 / 3.0 * np.pi * radius**3
    return (mesh.signed_volume - exact) / exact
