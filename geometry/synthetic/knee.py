"""A synthetic knee built from formulas, for tests that must not depend on scanned data.

Units mm; frame x right, y anterior, z superior; a RIGHT knee (medial compartment at -x).

* Femur: the lower caps of two ellipsoids (one per condyle), cut where
  (X/a)² + (Y/b)² = CAP_RHO² (`CAP_RHO`; about 67° up the side), as one open sheet of two
  connected components. Vertices lie on the ellipsoid; faces wind so that their normals
  point OUT of the ellipsoid (down, away from the bone, towards the tibia).
* Tibia: one square patch per compartment, z = f(x, y) = a shallow dish rising away
  from the patch centre plus a sinusoidal bump (amplitude `BUMP_MM`, wavelength
  `WAVELENGTH_MM`), normals up (+z). The two patches are two connected components of
  one mesh (`tibia_mesh`), or two meshes (`tibia_compartment`); they lie on either side
  of the sagittal plane x = 0 (a "sagittal" split at 0 separates them).

Each patch is placed so that its lowest vertical gap to its ellipsoid is `GAP_MM` of the
compartment at the reference pose (tibia z shift 0): the medial condyle touches, the
lateral one stands off, so that the medial/lateral split of the load is not 50/50 by
symmetry. Under a +z load the tibia moves up (+z) into the femur.

Writers put the meshes in a folder as STL, OBJ or VTU, in mm or m (points / 1000).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from geometry.io import save_mesh
from geometry.mesh import TriMesh

COMPARTMENTS = ("medial", "lateral")
CAP_RHO = 0.92
"""The femoral caps keep the part of the ellipsoid below (X/a)² + (Y/b)² = CAP_RHO²."""
BUMP_MM = 0.4
WAVELENGTH_MM = (12.0, 14.0)
DISH_RADIUS_MM = 90.0
PATCH_HALF_MM = 13.0
FEMUR_SPACING_MM = 0.9
TIBIA_SPACING_MM = 0.8


@dataclass(frozen=True)
class Condyle:
    """An ellipsoidal condyle over its tibial patch (mm).

    centre : ellipsoid centre (x, y, z); axes : semi-axes (a along x, b along y, c along z)
    patch_centre : (x, y) of the tibial patch; gap : lowest vertical femur-tibia gap at
    the reference pose; phase : phase of the patch's bump (rad)
    """

    centre: tuple[float, float, float]
    axes: tuple[float, float, float]
    patch_centre: tuple[float, float]
    gap: float
    phase: float


CONDYLES = {
    "medial": Condyle((-22.0, 1.0, 20.0), (20.0, 25.0, 18.0), (-22.5, 0.0), 0.0, 0.7),
    "lateral": Condyle((22.0, -1.5, 19.0), (18.0, 23.0, 17.0), (22.5, 0.0), 0.15, 2.1),
}


def _grid_faces(nx: int, ny: int, keep: np.ndarray | None = None) -> np.ndarray:
    """Faces of an (nx × ny)-vertex grid (index i·ny + j), two triangles per cell, counter-
    clockwise seen from +z; `keep` (nx-1, ny-1) selects cells. Diagonals alternate."""
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="ij")
    if keep is not None:
        i, j = i[keep], j[keep]
    i, j = i.ravel(), j.ravel()
    p00, p10 = i * ny + j, (i + 1) * ny + j
    p01, p11 = p00 + 1, p10 + 1
    flip = (i + j) % 2 == 1
    a = np.where(flip[:, None], np.stack([p00, p10, p01], 1), np.stack([p00, p10, p11], 1))
    b = np.where(flip[:, None], np.stack([p10, p11, p01], 1), np.stack([p00, p11, p01], 1))
    return np.concatenate([a, b])


def _compact(points: np.ndarray, faces: np.ndarray) -> TriMesh:
    used = np.unique(faces)
    remap = np.full(len(points), -1)
    remap[used] = np.arange(len(used))
    return TriMesh(points[used], remap[faces])


def _merge(meshes: list[TriMesh]) -> TriMesh:
    offsets = np.cumsum([0] + [m.n_points for m in meshes[:-1]])
    return TriMesh(np.concatenate([m.points for m in meshes]),
                   np.concatenate([m.faces + o for m, o in zip(meshes, offsets, strict=True)]))


# ------------------------------------------------------------------------------ femur
def femur_height(c: Condyle, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """z of the ellipsoid's lower surface above (x, y) (NaN outside its outline)."""
    (x0, y0, z0), (a, b, cz) = c.centre, c.axes
    r2 = ((x - x0) / a) ** 2 + ((y - y0) / b) ** 2
    with np.errstate(invalid="ignore"):
        return z0 - cz * np.sqrt(1.0 - r2)


def condyle_cap(c: Condyle, spacing: float = FEMUR_SPACING_MM) -> TriMesh:
    """The condyle's lower cap: a grid over its outline lifted onto the ellipsoid (cells
    whose four corners lie within `CAP_RHO`), normals out of the ellipsoid (down)."""
    (x0, y0, _), (a, b, _) = c.centre, c.axes
    # the grid is offset by a third of a spacing so that it never lines up with the tibia's
    u = np.arange(-a, a + spacing, spacing) + spacing / 3
    v = np.arange(-b, b + spacing, spacing) + spacing / 3
    X, Y = np.meshgrid(x0 + u, y0 + v, indexing="ij")
    inside = ((X - x0) / a) ** 2 + ((Y - y0) / b) ** 2 <= CAP_RHO ** 2
    keep = inside[:-1, :-1] & inside[1:, :-1] & inside[:-1, 1:] & inside[1:, 1:]
    Z = np.where(inside, femur_height(c, X, Y), 0.0)
    points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    faces = _grid_faces(len(u), len(v), keep)[:, ::-1]      # reversed: normals down
    return _compact(points, faces)


def femur_mesh(spacing: float = FEMUR_SPACING_MM) -> TriMesh:
    """Both condyle caps in one mesh (two connected components), mm."""
    return _merge([condyle_cap(CONDYLES[c], spacing) for c in COMPARTMENTS])


# ------------------------------------------------------------------------------ tibia
def _plateau_shape(c: Condyle, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The patch's shape before placement: dish + bump, mm."""
    X, Y = x - c.patch_centre[0], y - c.patch_centre[1]
    lx, ly = WAVELENGTH_MM
    dish = (X ** 2 + Y ** 2) / (2.0 * DISH_RADIUS_MM)
    bump = BUMP_MM * np.sin(2 * np.pi * X / lx + c.phase) * np.cos(2 * np.pi * (Y - 1.5) / ly)
    return dish + bump


def plateau_offset(c: Condyle, step: float = 0.02) -> float:
    """z offset that puts the patch's lowest vertical gap to the ellipsoid at `c.gap`
    (on a dense grid of the patch)."""
    u = np.arange(-PATCH_HALF_MM, PATCH_HALF_MM + step, step)
    X, Y = np.meshgrid(c.patch_centre[0] + u, c.patch_centre[1] + u, indexing="ij")
    gap = femur_height(c, X, Y) - _plateau_shape(c, X, Y)
    return float(np.nanmin(gap)) - c.gap


def plateau_height(c: Condyle, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """z of the placed tibial patch above (x, y), mm."""
    return _plateau_shape(c, x, y) + plateau_offset(c)


def tibia_compartment(name: str, spacing: float = TIBIA_SPACING_MM) -> TriMesh:
    """The tibial patch of one compartment: a square grid, normals up (+z)."""
    c = CONDYLES[name]
    n = int(round(2 * PATCH_HALF_MM / spacing)) + 1
    u = np.linspace(-PATCH_HALF_MM, PATCH_HALF_MM, n)
    X, Y = np.meshgrid(c.patch_centre[0] + u, c.patch_centre[1] + u, indexing="ij")
    Z = plateau_height(c, X, Y)
    points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    return TriMesh(points, _grid_faces(n, n))


def tibia_mesh(spacing: float = TIBIA_SPACING_MM) -> TriMesh:
    """Both patches in one mesh (two connected components, medial first), mm."""
    return _merge([tibia_compartment(c, spacing) for c in COMPARTMENTS])


# ------------------------------------------------------------------------------ files
UNIT_SCALE = {"mm": 1.0, "m": 1e-3}


def write_mesh(mesh: TriMesh, path: Path, units: str = "mm") -> Path:
    """Write `mesh` (mm) to `path` (format from the extension) in `units` ("mm" or "m")."""
    return save_mesh(TriMesh(mesh.points * UNIT_SCALE[units], mesh.faces), path)


def write_knee(folder: Path, fmt: str = "stl", units: str = "mm",
               layout: str = "components") -> dict[str, str]:
    """Write the femur and the tibia into `folder`; the [geometry] keys naming them.

    layout : "components" (one tibia file, its two connected components), "sagittal"
        (one tibia file, split at x = 0) or "two-files" (tibia = medial, tibia_lateral)
    """
    folder = Path(folder)
    keys = {"units": units, "femur": f"femur.{fmt}"}
    write_mesh(femur_mesh(), folder / keys["femur"], units)
    if layout == "two-files":
        keys["tibia"], keys["tibia_lateral"] = f"tibia_medial.{fmt}", f"tibia_lateral.{fmt}"
        write_mesh(tibia_compartment("medial"), folder / keys["tibia"], units)
        write_mesh(tibia_compartment("lateral"), folder / keys["tibia_lateral"], units)
        return keys
    keys["tibia"] = f"tibia.{fmt}"
    write_mesh(tibia_mesh(), folder / keys["tibia"], units)
    if layout == "sagittal":
        keys["tibia_split"], keys["split_x_mm"] = "sagittal", 0.0
    elif layout == "components":
        keys["tibia_split"] = "components"
    else:
        raise ValueError(f"unknown layout {layout!r}")
    return keys
