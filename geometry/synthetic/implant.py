"""A total knee replacement and a test cylinder built from formulas, for the FE of closed
tibial solids (`fecheck.fe.bodies.volume`): `validation/fe_implant.py` and the tests use them;
``python validation/implant_pair.py`` writes them with their scene.

Units mm, N, MPa; frame x right, y anterior, z superior; a RIGHT knee (medial at -x).

* Femoral component (rigid): two toroidal condyles at x = ±`CONDYLE_X_MM`, distal
  sagittal radius `SAGITTAL_MM` (40) and frontal radius `FRONTAL_MM` (20): each the
  torus whose tube (radius FRONTAL) runs on a circle of radius SAGITTAL - FRONTAL in the
  sagittal plane. Only the lower patch (|x - x_c| ≤ 14 mm, |y - y_c| ≤ 20 mm) is
  written, as one open sheet of two pieces with normals down. The condyles stand
  `FEMUR_Y_MM` anterior of the dwells (a small antero-posterior offset, so that the
  contact sits on the dwells' anterior slopes), the lateral one `LATERAL_GAP_MM` higher.
* Insert (UHMWPE, E 463 MPa, ν 0.45): a block x ∈ ±`HALF_WIDTH_MM`, y ∈ ±`HALF_DEPTH_MM`
  on a flat base plane z = -`BASE_DEPTH_MM` (fixed: the tray), free vertical walls, and
  a dished top: per compartment the concave torus of radii SAGITTAL / `CONFORMITY[0]`
  (sagittal) and FRONTAL / `CONFORMITY[1]` (frontal), lowest at (±CONDYLE_X, 0, 0),
  the two dwells meeting in a ridge at x = 0 and the top capped at z = `RIM_MM`. The
  insert is 7 mm thick under the dwells and 12 mm at the rim. Its closed surface is
  meshed by Gmsh (a box's faces, fine on the top over the dwells, coarse on the base
  and walls) and lifted onto the dished top; the articular sheet is its top face.

At the reference pose (tibia z shift 0) the medial condyle touches its dwell (lowest
vertical gap 0); under a +z load on the tibia it presses in.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from geometry.gmsh_session import gmsh_session, surface_triangles
from geometry.io import save_mesh
from geometry.mesh import TriMesh

SAGITTAL_MM, FRONTAL_MM = 40.0, 20.0
CONFORMITY = (0.90, 0.95)
"""Femoral / insert radius, sagittal and frontal."""
CONDYLE_X_MM = 20.0
FEMUR_Y_MM = 0.5
LATERAL_GAP_MM = 0.01
HALF_WIDTH_MM, HALF_DEPTH_MM = 36.0, 24.0
BASE_DEPTH_MM = 7.0
RIM_MM = 5.0
YOUNGS_MPA, POISSON, LOAD_N = 463.0, 0.45, 2000.0
COMPARTMENT_X = {"medial": -CONDYLE_X_MM, "lateral": CONDYLE_X_MM}


def _oriented(points: np.ndarray, faces: np.ndarray) -> TriMesh:
    """The closed surface wound consistently outward (trimesh's winding repair)."""
    import trimesh

    mesh = trimesh.Trimesh(points, faces, process=False)
    trimesh.repair.fix_normals(mesh)
    return TriMesh(np.asarray(mesh.vertices), np.asarray(mesh.faces))


# --------------------------------------------------------------------------- cylinder
def cylinder_solid(radius: float, height: float, fine_mm: float, fine_radius: float,
                   coarse_mm: float) -> TriMesh:
    """Closed outward surface of the cylinder r ≤ `radius`, -`height` ≤ z ≤ 0, triangles
    of `fine_mm` within `fine_radius` of the top centre growing to `coarse_mm`."""
    with gmsh_session("cylinder") as gmsh:
        gmsh.model.occ.addCylinder(0, 0, -height, 0, 0, height, radius)
        gmsh.model.occ.synchronize()
        field = gmsh.model.mesh.field
        dist = field.add("Distance")
        field.setNumbers(dist, "PointsList", [gmsh.model.occ.addPoint(0, 0, 0)])
        gmsh.model.occ.synchronize()
        thr = field.add("Threshold")
        field.setNumber(thr, "InField", dist)
        for name, value in (("SizeMin", fine_mm), ("SizeMax", coarse_mm),
                            ("DistMin", fine_radius), ("DistMax", 2.5 * fine_radius + height)):
            field.setNumber(thr, name, value)
        field.setAsBackgroundMesh(thr)
        for option in ("MeshSizeFromPoints", "MeshSizeFromCurvature",
                       "MeshSizeExtendFromBoundary"):
            gmsh.option.setNumber(f"Mesh.{option}", 0)
        gmsh.model.mesh.generate(2)
        points, faces = surface_triangles(gmsh)
    return _oriented(points, faces)


# --------------------------------------------------------------------------- implant
def _dwell_height(x: np.ndarray, y: np.ndarray, xc: float) -> np.ndarray:
    """z of one concave toroidal dwell lowest at (xc, 0, 0) (inf where undefined)."""
    rs, rf = SAGITTAL_MM / CONFORMITY[0], FRONTAL_MM / CONFORMITY[1]
    with np.errstate(invalid="ignore"):
        tube = (rs - rf) + np.sqrt(rf ** 2 - (x - xc) ** 2)
        z = rs - np.sqrt(tube ** 2 - y ** 2)
    return np.where(np.isfinite(z), z, np.inf)


def insert_height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """z of the insert's dished top above (x, y), mm."""
    both = np.minimum(_dwell_height(x, y, -CONDYLE_X_MM), _dwell_height(x, y, CONDYLE_X_MM))
    return np.minimum(both, RIM_MM)


def contact_y(femur_y_mm: float) -> float:
    """y of the rigid first contact of a condyle `femur_y_mm` anterior of its dwell, mm
    (the sagittal circles' common normal through both centres)."""
    rs = SAGITTAL_MM / CONFORMITY[0]
    return rs * float(np.sin(np.arctan2(femur_y_mm, rs - SAGITTAL_MM)))


def insert_solid(fine_mm: float = 1.0, coarse_mm: float = 4.0, fine_radius: float = 12.0,
                 femur_y_mm: float = FEMUR_Y_MM) -> tuple[TriMesh, np.ndarray]:
    """The insert's closed outward surface and the indices of its top (articular) faces:
    top triangles of `fine_mm` within `fine_radius` of each first contact (`contact_y`),
    growing to `coarse_mm` 10 mm further and on the base."""
    with gmsh_session("insert") as gmsh:
        gmsh.model.occ.addBox(-HALF_WIDTH_MM, -HALF_DEPTH_MM, -BASE_DEPTH_MM,
                              2 * HALF_WIDTH_MM, 2 * HALF_DEPTH_MM, BASE_DEPTH_MM)
        gmsh.model.occ.synchronize()
        ring = f"Sqrt((Abs(x)-{CONDYLE_X_MM})^2 + (y-{contact_y(femur_y_mm)})^2)"
        grow = f"Min(Max(({ring}-{fine_radius})/10, -z/{BASE_DEPTH_MM}), 1)"
        field = gmsh.model.mesh.field
        size = field.add("MathEval")
        field.setString(size, "F", f"{fine_mm} + {coarse_mm - fine_mm}*Max({grow}, 0)")
        field.setAsBackgroundMesh(size)
        for option in ("MeshSizeFromPoints", "MeshSizeFromCurvature",
                       "MeshSizeExtendFromBoundary"):
            gmsh.option.setNumber(f"Mesh.{option}", 0)
        gmsh.model.mesh.generate(2)
        points, faces = surface_triangles(gmsh)
    top_z = insert_height(points[:, 0], points[:, 1])
    on_top = np.isclose(points[:, 2], 0.0)
    lifted = points.copy()
    lifted[:, 2] = -BASE_DEPTH_MM + (points[:, 2] + BASE_DEPTH_MM) * (
        (top_z + BASE_DEPTH_MM) / BASE_DEPTH_MM)
    return _oriented(lifted, faces), np.flatnonzero(on_top[faces].all(axis=1))


def insert_sheet(solid: TriMesh, top: np.ndarray) -> TriMesh:
    """The insert's articular sheet: its top faces, normals up."""
    used, inverse = np.unique(solid.faces[top], return_inverse=True)
    return TriMesh(solid.points[used], inverse.reshape(-1, 3))


def femur_height(x: np.ndarray, y: np.ndarray, compartment: str, femur_y_mm: float
                 ) -> np.ndarray:
    """z of a toroidal condyle's lower surface above (x, y), mm."""
    xc = COMPARTMENT_X[compartment]
    rs, rf = SAGITTAL_MM, FRONTAL_MM
    tube = (rs - rf) + np.sqrt(rf ** 2 - (x - xc) ** 2)
    zc = _femur_centre_z(compartment, femur_y_mm)
    return zc - np.sqrt(tube ** 2 - (y - femur_y_mm) ** 2)


def _femur_centre_z(compartment: str, femur_y_mm: float, step: float = 0.02) -> float:
    """Height of the condyle's torus axis that puts its lowest vertical gap to the
    insert's top at 0 (medial) or LATERAL_GAP_MM (lateral), on a dense grid."""
    xc = COMPARTMENT_X[compartment]
    u = np.arange(-10.0, 10.0 + step, step)
    X, Y = np.meshgrid(xc + u, contact_y(femur_y_mm) + u, indexing="ij")
    tube = (SAGITTAL_MM - FRONTAL_MM) + np.sqrt(FRONTAL_MM ** 2 - (X - xc) ** 2)
    lower = -np.sqrt(tube ** 2 - (Y - femur_y_mm) ** 2)        # condyle z with zc = 0
    gap = float(np.min(lower - insert_height(X, Y)))
    return -gap + (LATERAL_GAP_MM if compartment == "lateral" else 0.0)


def femur_sheet(femur_y_mm: float = FEMUR_Y_MM, spacing: float = 0.7) -> TriMesh:
    """Both condyles' lower patches (two pieces), normals down, mm."""
    u = np.arange(-14.0, 14.0 + 1e-9, spacing)
    v = np.arange(-20.0, 20.0 + 1e-9, spacing)
    nu, nv = len(u), len(v)
    i, j = np.meshgrid(np.arange(nu - 1), np.arange(nv - 1), indexing="ij")
    p00 = (i * nv + j).ravel()
    quads = np.column_stack([p00, p00 + nv, p00 + nv + 1, p00 + 1])
    grid = np.concatenate([quads[:, [0, 2, 1]], quads[:, [0, 3, 2]]])   # normals down
    parts, faces, offset = [], [], 0
    for c, xc in COMPARTMENT_X.items():
        X, Y = np.meshgrid(xc + u, femur_y_mm + v, indexing="ij")
        z = femur_height(X, Y, c, femur_y_mm)
        parts.append(np.column_stack([X.ravel(), Y.ravel(), z.ravel()]))
        faces.append(grid + offset)
        offset += nu * nv
    return TriMesh(np.concatenate(parts), np.concatenate(faces))


SCENE = """name = "implant_synthetic"
gravity = false

[model]
kind = "femur-tibia"

[geometry]
femur = "femur.stl"
tibia = "insert_top.stl"
tibia_split = "sagittal"
split_x_mm = 0.0
tibia_solid = "insert.stl"

[knee]
preset = "custom"
side = "right"

[contact]
law = "ef"
area = "clipped"
youngs_MPa = {E}
poisson = {nu}
thickness_mm = {h}

[load]
force_N = {F}
point_mm = [0.0, 0.0, -400.0]
direction = [0.0, 0.0, 1.0]

[ligaments]
model = "none"

[dofs]
free = ["z"]
"""


def write_implant(folder: Path, femur_y_mm: float = FEMUR_Y_MM, fine_mm: float = 1.0,
                  coarse_mm: float = 4.0) -> Path:
    """Write femur.stl, insert.stl (closed), insert_top.stl and implant.toml into
    `folder`, the condyles `femur_y_mm` anterior of the dwells; the scene's path. The
    EF's uniform thickness is the insert's under the dwells (`BASE_DEPTH_MM`)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    solid, top = insert_solid(fine_mm, coarse_mm, femur_y_mm=femur_y_mm)
    save_mesh(solid, folder / "insert.stl")
    save_mesh(insert_sheet(solid, top), folder / "insert_top.stl")
    save_mesh(femur_sheet(femur_y_mm), folder / "femur.stl")
    scene = folder / "implant.toml"
    scene.write_text(SCENE.format(E=YOUNGS_MPA, nu=POISSON, h=BASE_DEPTH_MM, F=LOAD_N),
                     encoding="utf-8")
    return scene
