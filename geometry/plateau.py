"""Tibial plateau meshes (thesis §3.1.1, §2.2.2): boxes, flat discs, polynomial surfaces.

Every builder meshes a flat 2D footprint (rectangle, ellipse or disc) with Gmsh's
frontal-Delaunay algorithm, optionally refined near a point, then lifts it onto the
contact surface. Solids are closed by a flat bottom and vertical side walls. Normals
point out of the solid; the contact surface is region ``"top"``.

Inclination (`plateau_box`): the top plane has sagittal angle λ and frontal angle γ as
defined in `geometry.fits` (z = ax + by + c with a = tan γ, b = tan λ / cos γ), i.e. the
box is rotated by R = Ry(-γ)·Rx(λ) about `center`, and its top normal is
(-a, -b, 1)/√(1 + a² + b²).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from geometry import budget
from geometry.cache import cached_build
from geometry.errors import FecheckError
from geometry.mesh import TriMesh
from geometry.polynomial import Polynomial2D

FOOTPRINTS = ("rectangle", "ellipse")


def _positive(name: str, value: float) -> float:
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        raise FecheckError(f"{name} must be a positive number of mm, got {value}")
    return v


def _vector(name: str, value: Sequence[float], n: int) -> np.ndarray:
    v = np.asarray(value, dtype=float)
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise FecheckError(f"{name} must be {n} finite coordinates in mm, got {value}")
    return v


def _refinement(refine_point, refine_size, refine_radius) -> tuple | None:
    given = [v is not None for v in (refine_point, refine_size, refine_radius)]
    if not any(given):
        return None
    if not all(given):
        raise FecheckError("refinement needs refine_point, refine_size and refine_radius "
                           "together")
    point = np.asarray(refine_point, dtype=float)
    if point.shape not in ((2,), (3,)) or not np.all(np.isfinite(point)):
        raise FecheckError(f"refine_point must be 2 or 3 finite coordinates, got {refine_point}")
    return (point[:2], _positive("refine_size", refine_size),
            _positive("refine_radius", refine_radius))


def rotation_from_angles(sagittal_deg: float, frontal_deg: float) -> np.ndarray:
    """R = Ry(-γ)·Rx(λ): turns e_z into the upward normal of a plane inclined by λ, γ."""
    lam, gam = np.radians(sagittal_deg), np.radians(frontal_deg)
    rx = np.array([[1, 0, 0], [0, np.cos(lam), -np.sin(lam)], [0, np.sin(lam), np.cos(lam)]])
    ry = np.array([[np.cos(-gam), 0, np.sin(-gam)], [0, 1, 0],
                   [-np.sin(-gam), 0, np.cos(-gam)]])
    return ry @ rx


def footprint_mesh(footprint: str, half_x: float, half_y: float, size: float,
                   refine: tuple | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate a rectangle or ellipse centred at the origin of the x-y plane (mm).

    Returns (n, 2) points and (m, 3) counter-clockwise faces. `refine` is
    (point_xy, size, radius): element size `size` within `radius` of the point, growing
    linearly (slope 0.5) to the global size outside.
    """
    from geometry.gmsh_session import gmsh_session, surface_triangles

    if footprint not in FOOTPRINTS:
        raise FecheckError(f"footprint must be one of {FOOTPRINTS}, got {footprint!r}")
    with gmsh_session("footprint") as gmsh:
        occ = gmsh.model.occ
        if footprint == "rectangle":
            occ.addRectangle(-half_x, -half_y, 0.0, 2 * half_x, 2 * half_y)
        elif half_x >= half_y:
            occ.addDisk(0.0, 0.0, 0.0, half_x, half_y)
        else:
            disk = occ.addDisk(0.0, 0.0, 0.0, half_y, half_x)
            occ.rotate([(2, disk)], 0, 0, 0, 0, 0, 1, np.pi / 2)
        occ.synchronize()
        opt = gmsh.option
        opt.setNumber("Mesh.Algorithm", 6)
        opt.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        opt.setNumber("Mesh.MeshSizeFromPoints", 0)
        opt.setNumber("Mesh.MeshSizeFromCurvature", 0)
        opt.setNumber("Mesh.MeshSizeMax", size)
        if refine is not None:
            (px, py), fine, radius = refine
            field = gmsh.model.mesh.field
            f = field.add("MathEval")
            dist = f"Sqrt((x-({px:.12g}))^2+(y-({py:.12g}))^2)"
            field.setString(f, "F", f"Min({size:.12g}, "
                                    f"{fine:.12g}+0.5*Max(0, {dist}-{radius:.12g}))")
            field.setAsBackgroundMesh(f)
        gmsh.model.mesh.generate(2)
        points, faces = surface_triangles(gmsh, 2)
    t = points[faces]
    cross_z = ((t[:, 1, 0] - t[:, 0, 0]) * (t[:, 2, 1] - t[:, 0, 1])
               - (t[:, 1, 1] - t[:, 0, 1]) * (t[:, 2, 0] - t[:, 0, 0]))
    faces = np.where((cross_z < 0)[:, None], faces[:, ::-1], faces)
    return points[:, :2].copy(), faces


def _rectangle2() -> tuple[np.ndarray, np.ndarray]:
    return np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]), np.array(
        [[0, 1, 2], [0, 2, 3]])


def extrude_down(points_xy: np.ndarray, faces: np.ndarray, top_z: np.ndarray,
                 bottom_z: float) -> TriMesh:
    """Close a lifted footprint (top z per vertex) into a solid with a flat bottom.

    Regions: ``"top"`` (the footprint's faces, normals up), ``"bottom"``, ``"side"``.
    """
    n, m = len(points_xy), len(faces)
    directed = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    _, inverse, counts = np.unique(np.sort(directed, axis=1), axis=0, return_inverse=True,
                                   return_counts=True)
    boundary = directed[counts[inverse.ravel()] == 1]
    a, b = boundary[:, 0], boundary[:, 1]
    side = np.concatenate([np.column_stack([a + n, b + n, b]), np.column_stack([a + n, b, a])])
    points = np.vstack([np.column_stack([points_xy, top_z]),
                        np.column_stack([points_xy, np.full(n, bottom_z)])])
    all_faces = np.vstack([faces, faces[:, ::-1] + n, side])
    regions = {"top": np.arange(m), "bottom": np.arange(m, 2 * m),
               "side": np.arange(2 * m, 2 * m + len(side))}
    return TriMesh(points, all_faces, regions)


def plateau_box(center: Sequence[float], size_x: float, size_y: float, thickness: float, *,
                sagittal_deg: float = 0.0, frontal_deg: float = 0.0,
                mesh_size: float | None = None, cache: bool = True) -> TriMesh:
    """A closed box whose top face (region ``"top"``) is the contact plane through `center`.

    Parameters
    ----------
    center : centre of the top face, mm
    size_x, size_y : top face extent before inclination, mm
    thickness : box depth below the top face, mm
    sagittal_deg, frontal_deg : inclination λ, γ (module docstring), degrees
    mesh_size : element size of top and bottom, mm; None gives the 12-triangle box

    >>> box = plateau_box((0, 0, -8.7), 80, 60, 10, cache=False)
    >>> box.n_faces, round(box.signed_volume)
    (12, 48000)
    """
    c = _vector("center", center, 3)
    sx, sy = _positive("size_x", size_x), _positive("size_y", size_y)
    h = _positive("thickness", thickness)
    if mesh_size is not None:
        _positive("mesh_size", mesh_size)
    for name, angle in (("sagittal_deg", sagittal_deg), ("frontal_deg", frontal_deg)):
        if not np.isfinite(angle) or abs(angle) >= 90:
            raise FecheckError(f"{name} must be within (-90, 90) degrees, got {angle}")
    if mesh_size is not None:                     # top and bottom: twice the footprint
        budget.guard_mesh("plateau_box", "triangles", sx * sy, float(mesh_size),
                          lambda s, f: [], copies=2.0, size_key="mesh_size")

    def build() -> TriMesh:
        if mesh_size is None:
            pts, faces = _rectangle2()
            pts = pts * [sx / 2, sy / 2]
        else:
            pts, faces = footprint_mesh("rectangle", sx / 2, sy / 2, float(mesh_size))
        box = extrude_down(pts, faces, np.zeros(len(pts)), -h)
        return box.transformed(rotation_from_angles(sagittal_deg, frontal_deg), c)

    params = {"center": c, "size": [sx, sy, h], "angles": [sagittal_deg, frontal_deg],
              "mesh_size": mesh_size}
    return cached_build("plateau-box", params, build, use_cache=cache)


def _frame(normal: np.ndarray) -> np.ndarray:
    """Rows e1, e2, n: an orthonormal frame with n the unit `normal`."""
    n = normal / np.linalg.norm(normal)
    ref = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = ref - (ref @ n) * n
    e1 /= np.linalg.norm(e1)
    return np.vstack([e1, np.cross(n, e1), n])


def plane_patch(center: Sequence[float], normal: Sequence[float], *, radius: float,
                size: float, refine_point: Sequence[float] | None = None,
                refine_size: float | None = None, refine_radius: float | None = None,
                cache: bool = True) -> TriMesh:
    """A flat disc of `radius` mm on the plane (center, normal), normals along `normal`.

    Element size `size` mm; `refine_size` within `refine_radius` of `refine_point` (its
    projection on the plane), growing with slope 0.5 outside. All faces are region
    ``"top"``. The in-plane axes are e1 = the projection of x (or y if the normal is near
    x) and e2 = n × e1.
    """
    c = _vector("center", center, 3)
    n = _vector("normal", normal, 3)
    if np.linalg.norm(n) == 0:
        raise FecheckError("plane normal must be a non-zero vector")
    r, h = _positive("radius", radius), _positive("size", size)
    frame = _frame(n)
    refine = _refinement(refine_point, refine_size, refine_radius)
    if refine is not None:
        p3 = np.asarray(refine_point, dtype=float)
        if p3.shape != (3,):
            raise FecheckError("plane_patch refine_point needs 3 coordinates (mm)")
        refine = ((frame[:2] @ (p3 - c)), refine[1], refine[2])
    _guard("plane_patch", math.pi * r * r, h, refine)

    def build() -> TriMesh:
        pts, faces = footprint_mesh("ellipse", r, r, h, refine)
        world = c + pts @ frame[:2]
        return TriMesh(world, faces, {"top": np.arange(len(faces))})

    params = {"center": c, "normal": frame[2], "radius": r, "size": h,
              "refine": None if refine is None else [list(refine[0]), refine[1], refine[2]]}
    return cached_build("plane-patch", params, build, use_cache=cache)


def _guard(builder: str, area: float, size: float, refine: tuple | None,
           copies: float = 1.0) -> None:
    """`geometry.budget.guard_mesh` of a footprint of `area` mm² meshed at `size` with
    `footprint_mesh`'s refinement (before the cache and Gmsh)."""
    def zones(s: float, fine: float) -> list[budget.Zone]:
        if refine is None:
            return []
        return [budget.Zone(fine, refine[2], refine[2] + 2.0 * (s - fine),
                            budget.point_on_plane)]

    budget.guard_mesh(builder, "triangles", area, size, zones, copies=copies,
                      refine_size=None if refine is None else refine[1])


def _poly_inputs(poly, footprint, center_xy, half_x, half_y, size, refine_point, refine_size,
                 refine_radius) -> tuple:
    if not isinstance(poly, Polynomial2D):
        raise FecheckError("poly must be a geometry.polynomial.Polynomial2D")
    if footprint not in FOOTPRINTS:
        raise FecheckError(f"footprint must be one of {FOOTPRINTS}, got {footprint!r}")
    cxy = _vector("center_xy", center_xy, 2)
    hx, hy = _positive("half_x", half_x), _positive("half_y", half_y)
    h = _positive("size", size)
    refine = _refinement(refine_point, refine_size, refine_radius)
    if refine is not None:
        refine = (refine[0] - cxy, refine[1], refine[2])
    return cxy, hx, hy, h, refine


def _footprint_area(footprint: str, hx: float, hy: float) -> float:
    return (4.0 if footprint == "rectangle" else math.pi) * hx * hy


def _lifted(poly, footprint, cxy, hx, hy, h, refine) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    pts, faces = footprint_mesh(footprint, hx, hy, h, refine)
    xy = pts + cxy
    return xy, faces, poly.value(xy[:, 0], xy[:, 1])


def polynomial_patch(poly: Polynomial2D, *, footprint: str = "rectangle",
                     center_xy: Sequence[float] = (0.0, 0.0), half_x: float, half_y: float,
                     size: float, refine_point: Sequence[float] | None = None,
                     refine_size: float | None = None, refine_radius: float | None = None,
                     cache: bool = True) -> TriMesh:
    """The surface z = poly(x, y) over a footprint (mm), normals up, region ``"top"``.

    The footprint (rectangle of half-sizes `half_x`, `half_y`, or the ellipse with those
    semi-axes) is centred at `center_xy`; `size` and the refinement are measured in the
    x-y projection.
    """
    cxy, hx, hy, h, refine = _poly_inputs(poly, footprint, center_xy, half_x, half_y, size,
                                          refine_point, refine_size, refine_radius)
    _guard("polynomial_patch", _footprint_area(footprint, hx, hy), h, refine)

    def build() -> TriMesh:
        xy, faces, z = _lifted(poly, footprint, cxy, hx, hy, h, refine)
        return TriMesh(np.column_stack([xy, z]), faces, {"top": np.arange(len(faces))})

    params = {"poly": poly, "footprint": footprint, "center_xy": cxy, "half": [hx, hy],
              "size": h, "refine": None if refine is None else [list(refine[0]), *refine[1:]]}
    return cached_build("polynomial-patch", params, build, use_cache=cache)


def polynomial_plateau(poly: Polynomial2D, *, footprint: str = "rectangle",
                       center_xy: Sequence[float] = (0.0, 0.0), half_x: float, half_y: float,
                       thickness: float, size: float,
                       refine_point: Sequence[float] | None = None,
                       refine_size: float | None = None, refine_radius: float | None = None,
                       cache: bool = True) -> TriMesh:
    """`polynomial_patch` closed into a solid: side walls and a flat bottom at
    min(f) - `thickness` (mm). Regions ``"top"``, ``"side"``, ``"bottom"``.
    """
    cxy, hx, hy, h, refine = _poly_inputs(poly, footprint, center_xy, half_x, half_y, size,
                                          refine_point, refine_size, refine_radius)
    t = _positive("thickness", thickness)
    _guard("polynomial_plateau", _footprint_area(footprint, hx, hy), h, refine, copies=2.0)

    def build() -> TriMesh:
        xy, faces, z = _lifted(poly, footprint, cxy, hx, hy, h, refine)
        return extrude_down(xy, faces, z, float(z.min()) - t)

    params = {"poly": poly, "footprint": footprint, "center_xy": cxy, "half": [hx, hy],
              "size": h, "thickness": t,
              "refine": None if refine is None else [list(refine[0]), *refine[1:]]}
    return cached_build("polynomial-plateau", params, build, use_cache=cache)
