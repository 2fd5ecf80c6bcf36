"""An articular sheet prepared for meshing: rims trimmed, terraces smoothed, remeshed at a
given element size with equilateral triangles.

A segmented cartilage sheet (marching cubes of a label) has what breaks an extrusion along
its normals: sliver faces (edges down to micrometres) whose normals point anywhere, rims
that curl down over the edge of the cartilage, and voxel terraces. An articular sheet
seen along its mean contact direction is a height field (a tibial plateau, the bottom of
a femoral condyle), so it is prepared as one:

1. axis a: the sheet's area-weighted mean face normal (or a given axis); the faces whose
   normal turns more than ``max_tilt_deg`` from it (curled rims, the cartilage's side
   walls) are trimmed, with every face of zero area (slivers);
2. the kept faces are projected on the plane normal to a; a regular lattice of
   equilateral triangles of side ``size_mm`` over that plane keeps the triangles whose
   three corners lie inside a projected kept face (the sheet's outline, to a lattice
   step);
3. the height h at each lattice vertex is the value there of the quadric
   a + b u + c v + d u² + e uv + f v² fitted by weighted least squares to samples
   (u_i, z_i) of the kept faces within ``smooth_mm`` of the vertex in the plane (the
   faces' vertices, split at edge midpoints until the edges are at most half the lattice
   step or a quarter of ``smooth_mm``; each weighted by its area times the biweight
   (1 − r²/smooth_mm²)² of its distance r): a local quadric regression
   (`quadric_heights`; its heights are kept in the mesh cache by the samples' content,
   `geometry.cache.cached_arrays`: `fecheck knee import` and `fecheck fe` prepare the
   same sheets). A quadric is reproduced exactly and a smooth shape nearly so
   (the synthetic plateau's 0.4 mm bump of 12 mm wavelength is kept to about 30 µm at
   4 mm), whatever ``size_mm``; voxel terraces and noise narrower than ``smooth_mm``
   are averaged out. (A smoothing spline that penalised curvature, the first version,
   flattened that bump and took 30 % off the FE p_max.) With ``smooth_mm`` 0 the
   heights are the least-squares fit of the samples on the lattice (h linear on its
   triangles; a vanishing penalty on second differences along the lattice lines holds
   every vertex).
   With ``terraces`` (a `geometry.terraces.TerraceFit`) a sheet cut from voxels (a
   staircase of flat terraces one voxel apart) is fitted instead as a whole: a thin-plate
   height field through the level lines half-way up its risers, pulled weakly (or not)
   toward the terraces (`geometry.terraces`); the quadric fits cannot tell where inside a
   terrace the surface lies, and at the flat bottom of a condyle put it up to half a
   step off.

The result's triangles are all equilateral in the plane (60° angles there; tilted by
at most ``max_tilt_deg`` in space); `transfer` interpolates values between the sheet
and the prepared sheet (projection on the plane, barycentric in the lattice).

Units: mm. Pure geometry: no mechanics here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from geometry.cache import cached_arrays
from geometry.errors import FecheckError
from geometry.mesh import TriMesh
from geometry.planar import inside_triangulation, locate_in_plane, plane_interpolation
from geometry.roughness import tributary_areas
from geometry.subdivide import subdivide
from geometry.terraces import Staircase, TerraceFit, staircase, terrace_heights

MAX_TILT_DEG = 65.0
"""Faces whose normal turns further than this from the sheet's axis are trimmed (rims)."""
SMOOTH_MM = 4.0
"""Default smoothing length of `prepare_sheet` (radius of the local quadric fits), mm."""
HOLD = 1e-6
"""Weight of the second differences in the least-squares heights (``smooth_mm`` 0): holds
a lattice vertex without samples, bends the others by a negligible amount."""


@dataclass(frozen=True, eq=False)
class PreparedSheet:
    """A prepared sheet and its plane.

    mesh : the remeshed sheet (normals on the axis's side)
    axis : (3,) unit axis (the plane's normal, on the side the sheet faces)
    origin : (3,) a point of the plane; frame : (2, 3) its in-plane unit vectors
    trimmed_faces : faces of the input sheet dropped as rims or slivers
    staircase : the voxel staircase found on the sheet (`geometry.terraces`), if any
    """

    mesh: TriMesh
    axis: np.ndarray
    origin: np.ndarray
    frame: np.ndarray
    trimmed_faces: int
    staircase: Staircase | None = None

    def plane(self, points: np.ndarray) -> np.ndarray:
        """(k, 2) in-plane coordinates of points (k, 3), mm."""
        return (points - self.origin) @ self.frame.T

    def transfer(self, points: np.ndarray, mesh: TriMesh | None = None) -> sp.csr_matrix:
        """(k, n) sparse interpolation from the vertex values of the prepared sheet (or of
        `mesh`, e.g. the prepared sheet subdivided) to points (k, 3) projected along the
        axis: barycentric in the triangle below, or the nearest vertex for points outside."""
        mesh = self.mesh if mesh is None else mesh
        return plane_interpolation(self.plane(mesh.points), mesh.faces, self.plane(points))


def sheet_axis(sheet: TriMesh) -> np.ndarray:
    """(3,) unit area-weighted mean face normal of `sheet`."""
    a = (sheet.face_normals * sheet.face_areas[:, None]).sum(axis=0)
    norm = np.linalg.norm(a)
    if not norm > 0:
        raise FecheckError("the sheet has no mean normal (its faces cancel out): it is not "
                           "an articular sheet")
    return a / norm


def prepare_sheet(sheet: TriMesh, size_mm: float, *, axis: np.ndarray | None = None,
                  max_tilt_deg: float = MAX_TILT_DEG, smooth_mm: float = SMOOTH_MM,
                  name: str = "sheet", terraces: TerraceFit | None = None) -> PreparedSheet:
    """The sheet remeshed as a height field over its axis (module docstring).

    size_mm : side of the equilateral triangles, mm; axis : (3,) direction the sheet faces
    (default `sheet_axis`); max_tilt_deg : rim trimming angle; smooth_mm : smoothing
    length, mm (0: least squares on the lattice); name : names the sheet in errors;
    terraces : fit a voxel staircase, when the sheet has one, as `geometry.terraces` does
    (None: never; the local quadric fits then, as on any sheet).
    """
    if not (np.isfinite(size_mm) and size_mm > 0):
        raise FecheckError(f"the element size of the prepared {name} must be a positive "
                           f"number of mm, got {size_mm}")
    a = sheet_axis(sheet) if axis is None else np.asarray(axis, float) / np.linalg.norm(axis)
    keep = (sheet.face_areas > 1e-12) & (sheet.face_normals @ a
                                         >= np.cos(np.radians(max_tilt_deg)))
    if keep.sum() < 3:
        raise FecheckError(f"the {name} has no faces within {max_tilt_deg:g} deg of its mean "
                           "normal: it is not an articular sheet")
    frame = _frame(a)
    origin = sheet.points[sheet.faces[keep]].reshape(-1, 3).mean(axis=0)
    uv = (sheet.points - origin) @ frame.T
    lattice, lattice_faces, lines = _lattice(uv[sheet.faces[keep]].reshape(-1, 2), size_mm)
    inside = inside_triangulation(lattice, uv, sheet.faces[keep])
    faces = lattice_faces[inside[lattice_faces].all(axis=1)]
    if len(faces) == 0:
        raise FecheckError(f"the {name} is narrower than one element of {size_mm:g} mm: "
                           "lower the element size")
    used = np.unique(faces)
    remap = np.full(len(lattice), -1)
    remap[used] = np.arange(len(used))
    lattice, faces = lattice[used], remap[faces]
    lines = remap[lines]
    lines = lines[(lines >= 0).all(axis=1)]
    kept = TriMesh(sheet.points, sheet.faces[keep])
    stair = None if terraces is None else staircase(kept, a, terraces.step_mm)
    h = None if stair is None else terrace_heights(lattice, faces, lines, kept, stair, origin,
                                                   frame, a, terraces)
    if h is None:
        stair = None
        dense, _ = subdivide(kept, _splits(sheet, max(0.5 * size_mm, 0.25 * smooth_mm)))
        used = np.unique(dense.faces)
        rel = dense.points[used] - origin
        suv, sz = rel @ frame.T, rel @ a
        if smooth_mm > 0:
            weight = tributary_areas(dense)[used]
            h = cached_arrays("quadric-heights", [lattice, suv, sz, weight,
                                                  np.array([smooth_mm], float)],
                              lambda: (quadric_heights(lattice, suv, sz, weight, smooth_mm),)
                              )[0]
        else:
            h = _least_squares_heights(lattice, faces, lines, suv, sz)
    points = origin + lattice @ frame + h[:, None] * a
    mesh = TriMesh(points, faces)
    return PreparedSheet(mesh, a, origin, frame, int((~keep).sum()), stair)


def _splits(sheet: TriMesh, step: float) -> int:
    """Midpoint splits of the sheet that bring its median edge to `step` or less (half the
    lattice step, so that every lattice triangle holds samples, or a quarter of the
    smoothing length if longer: enough samples in each quadric fit, and no more)."""
    edges = np.linalg.norm(sheet.points[sheet.faces[:, [1, 2, 0]]] - sheet.points[sheet.faces],
                           axis=2)
    return int(np.clip(np.ceil(np.log2(np.median(edges) / step)), 0, 4))


def _frame(a: np.ndarray) -> np.ndarray:
    """(2, 3) in-plane unit vectors e1, e2 with e1 × e2 = a."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(helper, a)
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(a, e1)])


def _lattice(uv: np.ndarray, size: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Equilateral lattice of side `size` covering the points uv (k, 2): its vertices (n, 2)
    (row j of vertices (i, j), i·ny + j, shifted by half a step on odd rows), its
    counter-clockwise triangles (m, 3) and its lines (t, 3): every three consecutive
    vertices on a line of the lattice (rows, and both diagonals)."""
    lo, hi = uv.min(axis=0) - size, uv.max(axis=0) + size
    dy = size * np.sqrt(3.0) / 2
    nx, ny = int(np.ceil((hi[0] - lo[0]) / size)) + 2, int(np.ceil((hi[1] - lo[1]) / dy)) + 1
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    pts = np.column_stack([(lo[0] + (i + 0.5 * (j % 2)) * size).ravel(),
                           (lo[1] + j * dy).ravel()])
    ci, cj = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="ij")
    ci, cj = ci.ravel(), cj.ravel()
    p00, p10 = ci * ny + cj, (ci + 1) * ny + cj
    p01, p11 = p00 + 1, p10 + 1
    even = (cj % 2) == 0
    # even rows: the row above is shifted right by half a step
    t1 = np.where(even[:, None], np.column_stack([p00, p10, p01]),
                  np.column_stack([p00, p11, p01]))
    t2 = np.where(even[:, None], np.column_stack([p10, p11, p01]),
                  np.column_stack([p00, p10, p11]))
    return pts, np.concatenate([t1, t2]), _lines(nx, ny)


def _lines(nx: int, ny: int) -> np.ndarray:
    """(t, 3) consecutive vertex triples (previous, middle, next) on the lattice's lines."""
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    i, j = i.ravel(), j.ravel()
    odd = j % 2
    steps = [((i - 1, j), (i + 1, j)),                              # along the rows
             ((i - 1 + odd, j - 1), (i + odd, j + 1)),              # up-right diagonal
             ((i + odd, j - 1), (i - 1 + odd, j + 1))]              # up-left diagonal
    out = []
    for (pi, pj), (qi, qj) in steps:
        ok = (pi >= 0) & (pi < nx) & (pj >= 0) & (pj < ny) & (qi >= 0) & (qi < nx) \
            & (qj >= 0) & (qj < ny)
        out.append(np.column_stack([pi * ny + pj, i * ny + j, qi * ny + qj])[ok])
    return np.concatenate(out)


def _least_squares_heights(lattice: np.ndarray, faces: np.ndarray, lines: np.ndarray,
                           uv: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Heights at the lattice vertices: the least-squares fit of the samples (uv, z) that
    fall on the lattice, h linear on its triangles, with a vanishing penalty (`HOLD`) on
    the second differences along the lattice's lines (module docstring, step 3)."""
    from scipy.sparse.linalg import spsolve

    n = len(lattice)
    face, w, inside = locate_in_plane(lattice, faces, uv)
    rows = np.repeat(np.arange(int(inside.sum())), 3)
    A = sp.csr_matrix((w[inside].ravel(), (rows, faces[face[inside]].ravel())),
                      shape=(int(inside.sum()), n))
    rows = np.repeat(np.arange(len(lines)), 3)
    D = sp.csr_matrix((np.tile([1.0, -2.0, 1.0], len(lines)), (rows, lines.ravel())),
                      shape=(len(lines), n))
    lhs = (A.T @ A + HOLD * inside.sum() / n * (D.T @ D)).tocsc()
    return np.asarray(spsolve(lhs, A.T @ z[inside])).ravel()


def quadric_heights(points: np.ndarray, uv: np.ndarray, z: np.ndarray, weight: np.ndarray,
                    radius: float) -> np.ndarray:
    """(n,) heights at the 2-D points (n, 2): at each, the value of the quadric
    a + b u + c v + d u² + e uv + f v² fitted by weighted least squares to the samples
    (uv (k, 2), heights z (k,)) within `radius` mm, sample j weighted by weight[j] (its
    area) times the biweight (1 − r²/radius²)² of its distance r (module docstring,
    step 3). A quadric is reproduced exactly; a point with too few samples for the
    quadric terms keeps the weighted mean (a small ridge on them)."""
    from scipy.spatial import cKDTree

    near = cKDTree(points).sparse_distance_matrix(cKDTree(uv), radius, output_type="ndarray")
    i, j = near["i"], near["j"]
    w = weight[j] * (1.0 - (near["v"] / radius) ** 2) ** 2
    d = (uv[j] - points[i]) / radius
    u, v = d[:, 0], d[:, 1]
    basis = np.column_stack([np.ones_like(u), u, v, u * u, u * v, v * v])
    n = len(points)
    normal = np.empty((n, 6, 6))
    for p in range(6):
        for q in range(p, 6):
            normal[:, p, q] = normal[:, q, p] = np.bincount(i, weights=w * basis[:, p]
                                                            * basis[:, q], minlength=n)
    rhs = np.column_stack([np.bincount(i, weights=w * basis[:, p] * z[j], minlength=n)
                           for p in range(6)])
    if not (normal[:, 0, 0] > 0).all():
        raise FecheckError(f"{int((normal[:, 0, 0] <= 0).sum())} points of the prepared sheet "
                           f"have no sample within the smoothing length of {radius:g} mm: "
                           "raise fe.smooth_mm")
    normal[:, np.arange(1, 6), np.arange(1, 6)] += 1e-12 * normal[:, :1, 0]
    return np.linalg.solve(normal, rhs[:, :, None])[:, 0, 0]
