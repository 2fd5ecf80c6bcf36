"""Cartilage layers as tetrahedral volume meshes (Gmsh), mm.

A layer of thickness ``h`` is meshed as a flat slab ``0 <= ζ <= h`` over its footprint
(rectangle or ellipse in the x-y plane), refined by Gmsh size fields around
``refine_point`` and, optionally, in a band along a circle of the top (the expected edge of
a contact patch), and then sheared vertically onto its top surface:
``z = z_top(x, y) - h + ζ``. The shear has unit Jacobian, so every vertical line keeps
the length ``h`` and the volume stays footprint area × h. The top surface is flat
(``z_top = 0`` at the footprint centre), inclined (``sagittal_deg`` tilts it about x,
``frontal_deg`` about y) or a `Polynomial2D` ``z_top = f(x, y)``.

Boundaries "top" and "bottom" are triangle sets (vertex indices into the tet mesh).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from geometry import budget
from geometry.cache import cached_build
from geometry.errors import FecheckError
from geometry.mesh import TetMesh
from geometry.polynomial import Polynomial2D

_FOOTPRINTS = ("rectangle", "ellipse")
#: Bump when the meshes this module builds change (the builder version in the cache key).
_BUILDER_VERSION = 2


def cartilage_layer(footprint: str = "rectangle", center_xy: Sequence[float] = (0.0, 0.0),
                    half_x: float = 30.0, half_y: float = 30.0, thickness: float = 6.0, *,
                    top: Polynomial2D | None = None, sagittal_deg: float = 0.0,
                    frontal_deg: float = 0.0, size: float = 5.0,
                    refine_point: Sequence[float] | None = None,
                    refine_size: float | None = None, refine_radius: float | None = None,
                    band_radius: float | None = None, band_size: float | None = None,
                    band_width: float = 1.5, order: int = 1, cache: bool = True) -> TetMesh:
    """Tetrahedral mesh of a cartilage layer bonded to bone on its bottom face.

    Parameters
    ----------
    footprint : "rectangle" or "ellipse" (outline in the x-y plane)
    center_xy : footprint centre, mm
    half_x, half_y : half-extents (semi-axes for an ellipse), mm
    thickness : layer thickness h, measured vertically, mm
    top : polynomial top surface z = f(x, y), mm (overrides the angles)
    sagittal_deg, frontal_deg : tilt of a plane top about x (slope dz/dy) and about y
        (slope dz/dx), degrees; the plane passes through z = 0 at the centre
    size : element size away from the refinement, mm
    refine_point : (x, y) of the point on the top surface to refine around (a mesh node
        is placed there), mm
    refine_size : element size at the refinement point, mm (default ``size``)
    refine_radius : radius of the disc around the point meshed at ``refine_size``, mm;
        sizes grow linearly to ``size`` over a further ``thickness + size``
    band_radius : radius of a circle on the top, centred on ``refine_point``, along which
        the mesh is refined to ``band_size`` (e.g. the expected contact edge), mm; None: no band
    band_size : element size within ``band_width`` of that circle, mm (default ``refine_size``);
        sizes grow linearly to ``size`` over a further ``band_width + size``
    band_width : half-width of the band (distance to the circle, in 3D), mm
    order : 1 (4-node tets) or 2 (10-node tets in Gmsh node order, mapped like the rest)
    cache : reuse a cached mesh built with the same parameters

    Returns
    -------
    TetMesh with boundaries "top" and "bottom" ((k, 3) or (k, 6) vertex indices).
    """
    if footprint not in _FOOTPRINTS:
        raise FecheckError(f"layer footprint must be one of {_FOOTPRINTS}, got {footprint!r}")
    numbers = {"half_x": half_x, "half_y": half_y, "thickness": thickness, "size": size}
    for name, value in numbers.items():
        if not np.isfinite(value) or value <= 0:
            raise FecheckError(f"layer {name} must be a positive length in mm, got {value}")
    if order not in (1, 2):
        raise FecheckError(f"layer mesh order must be 1 or 2, got {order}")
    rsize = size if refine_size is None else float(refine_size)
    if not (np.isfinite(rsize) and 0 < rsize <= size):
        raise FecheckError(f"refine_size must be in (0, size={size}] mm, got {refine_size}")
    rradius = 0.0 if refine_radius is None else float(refine_radius)
    if not np.isfinite(rradius) or rradius < 0:
        raise FecheckError(f"refine_radius must be a non-negative length, got {refine_radius}")
    if band_radius is not None:
        if refine_point is None:
            raise FecheckError("a refinement band needs refine_point (its centre)")
        bsize = rsize if band_size is None else float(band_size)
        band = {"band_radius": float(band_radius), "band_size": bsize,
                "band_width": float(band_width)}
        if not all(np.isfinite(v) and v > 0 for v in band.values()) or bsize > size:
            raise FecheckError(f"the refinement band needs a positive radius and width and a "
                               f"size in (0, size={size}] mm, got {band}")
    else:
        band = None
    _guard(footprint, half_x * half_y * thickness, thickness, size, refine_size,
           rradius if refine_point is not None else None, band, order)
    params = {"footprint": footprint, "center_xy": [float(c) for c in center_xy],
              "half_x": half_x, "half_y": half_y, "thickness": thickness, "top": top,
              "sagittal_deg": sagittal_deg, "frontal_deg": frontal_deg, "size": size,
              "refine_point": None if refine_point is None else [float(c) for c in refine_point],
              "refine_size": rsize, "refine_radius": rradius, "band": band, "order": order}

    def build() -> TetMesh:
        return _build_layer(**params)

    return cached_build("cartilage_layer", params, build, use_cache=cache,
                        version=_BUILDER_VERSION)


def _guard(footprint: str, half_product: float, thickness: float, size: float,
           refine_size: float | None, refine_radius: float | None, band: dict | None,
           order: int) -> None:
    """`geometry.budget.guard_mesh` of a layer (before the cache and Gmsh): volume
    footprint area × thickness, refined around the point (a half ball on the top, then
    the slab) and along the band."""
    volume = (4.0 if footprint == "rectangle" else math.pi) * half_product

    def zones(s: float, fine: float) -> list[budget.Zone]:
        out = []
        if refine_radius is not None:
            out.append(budget.Zone(fine, refine_radius, refine_radius + thickness + s,
                                   budget.point_on_slab(thickness)))
        if band is not None:
            w = band["band_width"]
            out.append(budget.Zone(band["band_size"], w, 2 * w + s,
                                   budget.circle_on_slab(band["band_radius"], thickness)))
        return out

    budget.guard_mesh("cartilage_layer",
                      "tetrahedra" if order == 1 else "quadratic tetrahedra", volume, size,
                      zones, refine_size=refine_size)


def top_height(points_xy: np.ndarray, center_xy: Sequence[float], top: Polynomial2D | None,
               sagittal_deg: float, frontal_deg: float) -> np.ndarray:
    """Height of the layer's top surface above the points (n, 2), mm."""
    x, y = points_xy[:, 0], points_xy[:, 1]
    if top is not None:
        return top.value(x, y)
    cx, cy = center_xy
    return (np.tan(np.radians(frontal_deg)) * (x - cx)
            + np.tan(np.radians(sagittal_deg)) * (y - cy))


def _build_layer(footprint: str, center_xy: list[float], half_x: float, half_y: float,
                 thickness: float, top: Polynomial2D | None, sagittal_deg: float,
                 frontal_deg: float, size: float, refine_point: list[float] | None,
                 refine_size: float, refine_radius: float, band: dict | None,
                 order: int) -> TetMesh:
    from geometry.gmsh_session import gmsh_session

    cx, cy = center_xy
    with gmsh_session("cartilage_layer") as gmsh:
        occ = gmsh.model.occ
        if footprint == "rectangle":
            base = occ.addRectangle(cx - half_x, cy - half_y, 0.0, 2 * half_x, 2 * half_y)
        else:
            rx, ry = max(half_x, half_y), min(half_x, half_y)
            disk = occ.addDisk(cx, cy, 0.0, rx, ry)
            if half_y > half_x:
                occ.rotate([(2, disk)], cx, cy, 0.0, 0, 0, 1, np.pi / 2)
            base = disk
        volume = occ.extrude([(2, base)], 0, 0, thickness)
        vol_tag = next(tag for dim, tag in volume if dim == 3)
        pt = None if refine_point is None else occ.addPoint(refine_point[0], refine_point[1],
                                                            thickness)
        occ.synchronize()
        top_tag, bottom_tag = _top_bottom_surfaces(gmsh, vol_tag, thickness)
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        min_size = min(size, refine_size, size if band is None else band["band_size"])
        gmsh.option.setNumber("Mesh.MeshSizeMin", min_size)
        if pt is not None:
            gmsh.model.mesh.embed(0, [pt], 2, top_tag)
            fields = [_refinement_field(gmsh, pt, refine_size, refine_radius, size, thickness)]
            if band is not None:
                fields.append(_band_field(gmsh, refine_point, thickness, size, **band))
            _set_background(gmsh, fields)
        gmsh.option.setNumber("Mesh.Algorithm3D", 10)
        gmsh.model.mesh.generate(3)
        if order == 2:
            gmsh.model.mesh.setOrder(2)
        points, tets, faces = _extract(gmsh, vol_tag, (top_tag, bottom_tag), order)
    zeta = points[:, 2].copy()
    points[:, 2] = top_height(points[:, :2], center_xy, top, sagittal_deg, frontal_deg) \
        - thickness + zeta
    return TetMesh(points, tets, {"top": faces[0], "bottom": faces[1]})


def _top_bottom_surfaces(gmsh, vol_tag: int, thickness: float) -> tuple[int, int]:
    top = bottom = None
    for dim, tag in gmsh.model.getBoundary([(3, vol_tag)], oriented=False):
        zmin, zmax = gmsh.model.getBoundingBox(dim, tag)[2::3]
        if abs(zmin - thickness) < 1e-5 and abs(zmax - thickness) < 1e-5:
            top = tag
        elif abs(zmin) < 1e-5 and abs(zmax) < 1e-5:
            bottom = tag
    if top is None or bottom is None:
        raise FecheckError("could not identify the layer's top and bottom faces in Gmsh")
    return top, bottom


def _refinement_field(gmsh, point_tag: int, refine_size: float, refine_radius: float,
                      size: float, thickness: float) -> int:
    field = gmsh.model.mesh.field
    dist = field.add("Distance")
    field.setNumbers(dist, "PointsList", [point_tag])
    thr = field.add("Threshold")
    field.setNumber(thr, "InField", dist)
    field.setNumber(thr, "SizeMin", refine_size)
    field.setNumber(thr, "SizeMax", size)
    field.setNumber(thr, "DistMin", refine_radius)
    field.setNumber(thr, "DistMax", refine_radius + thickness + size)
    return thr


def _band_field(gmsh, center: list[float], thickness: float, size: float, band_radius: float,
                band_size: float, band_width: float) -> int:
    """Size field: ``band_size`` within ``band_width`` (3D distance) of the top circle."""
    field = gmsh.model.mesh.field
    cx, cy, a, h = (f"({float(v):.15g})" for v in (*center, band_radius, thickness))
    dist = field.add("MathEval")
    rho = f"Sqrt((x - {cx})*(x - {cx}) + (y - {cy})*(y - {cy}))"
    field.setString(dist, "F", f"Sqrt(({rho} - {a})*({rho} - {a}) + (z - {h})*(z - {h}))")
    thr = field.add("Threshold")
    field.setNumber(thr, "InField", dist)
    field.setNumber(thr, "SizeMin", band_size)
    field.setNumber(thr, "SizeMax", size)
    field.setNumber(thr, "DistMin", band_width)
    field.setNumber(thr, "DistMax", 2 * band_width + size)
    return thr


def _set_background(gmsh, fields: list[int]) -> None:
    """Use the smallest of the size fields everywhere; ignore boundary and point sizes."""
    field = gmsh.model.mesh.field
    if len(fields) == 1:
        field.setAsBackgroundMesh(fields[0])
    else:
        low = field.add("Min")
        field.setNumbers(low, "FieldsList", fields)
        field.setAsBackgroundMesh(low)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)


def _extract(gmsh, vol_tag: int, surf_tags: tuple[int, int],
             order: int) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    tet_type, tri_type = (4, 2) if order == 1 else (11, 9)
    node_tags, coords, _ = gmsh.model.mesh.getNodes()
    node_tags = node_tags.astype(np.int64)
    lookup = np.full(node_tags.max() + 1, -1, dtype=np.int64)
    lookup[node_tags] = np.arange(len(node_tags))
    points = coords.reshape(-1, 3)
    _, tet_nodes = gmsh.model.mesh.getElementsByType(tet_type, vol_tag)
    tets = lookup[tet_nodes.astype(np.int64)].reshape(-1, 4 if order == 1 else 10)
    faces = []
    for tag in surf_tags:
        _, tri_nodes = gmsh.model.mesh.getElementsByType(tri_type, tag)
        faces.append(lookup[tri_nodes.astype(np.int64)].reshape(-1, 3 if order == 1 else 6))
    used, inverse = np.unique(tets, return_inverse=True)
    remap = np.full(len(points), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    tets = inverse.reshape(tets.shape)
    return points[used].copy(), tets, [remap[f] for f in faces]
