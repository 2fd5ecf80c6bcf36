"""Meniscus solids for the FE with menisci: tetrahedra, surfaces, fibres, horns.

`meniscus_solid` turns one meniscus of the smith2019 data set (``menisci.dir``, e.g. the
packaged ``fecheck:knee/smith2019_menisci``) into plain data for a deformable meniscus:

* **Mesh.** Linear tetrahedra (P1; scikit-fem adds the P2 nodes) filling the closed volume
  surface, whose triangles are kept as the boundary (`fecheck.fe.bodies.volume.tetrahedralize`),
  so the tet mesh has the STL's volume exactly; ``size_mm`` bounds the interior edges
  (Gmsh ``Mesh.MeshSizeMax``) and, well below the surface's own median edge (0.95 / 0.90
  mm medial / lateral), splits the surface triangles in four as often as brings the
  median edge nearest it (on a log scale); Netgen's optimiser removes the slivers
  (minimum dihedral angle 0.3 -> 3.0 deg medially). Measured
  on the packaged menisci: Gmsh's remeshing of the classified STL (``classifySurfaces`` /
  ``createGeometry``) loses 1.8-3.8 % of the volume at 1-1.5 mm (it cuts the STL's
  0.4-0.8 mm bumps), fails on the lateral one, and with curvature sizing makes 30-90
  thousand tetrahedra; hence the kept boundary. One fold of the lateral STL (two faces
  turned 179 deg on each other at (21.0, -7.4, -0.3) mm, which Gmsh rejects as a
  self-intersection) is removed first by moving the fold's vertices to the mean of their
  neighbours (`unfold`; 0.01 % of the volume). Cached on disk by the surface's content and
  the size (`geometry.cache`).
* **Surfaces.** Each boundary face is superior (femur-facing), inferior (tibia-facing) or
  wall (the free peripheral rim, the inner wall and the horn ends): superior or inferior
  when its centroid lies within ``tolerance_mm`` of that packaged articular surface, over
  it rather than past its rim, and its normal within 60 deg of the surface's there (the
  surfaces lie on the volume within 0.22 mm, the data set's README), the nearer one
  winning. The labelled areas exceed the packaged surfaces' by 2.0-3.2 % (the volume's
  surface is the rougher) and cover 99.9-100 % of them. Each face also gets the region
  (1 anterior horn, 2 body, 3 posterior horn) of the nearest of the packaged regions.
* **Fibres.** The circumferential direction per element is the tangent of the meniscus's
  centreline: the element centroids are sorted by angle φ about a circle fitted to the
  footprint (in the plane normal to ``axis``, the tibia's z) from one edge of the C's
  opening to the other and binned; the bins' volume-mean distance from the centre and
  height, as functions of φ, are fitted by Chebyshev series of degree 5 (a Cartesian
  spline through the bins' centroids followed their 0.1 mm scatter: 4 deg errors on the
  torus segment of the tests, now 0.2 deg, 0.7 deg at the tips), and the curve is
  extended straight past its ends; each element takes the tangent and arc length of its
  closest centreline point. The arc coordinate is 0 at the anterior horn tip and 1 at the
  posterior one (the ends of the boundary's arc lengths).
* **Horns.** The anterior and posterior horn node sets (the boundary nodes of the inferior
  and wall faces of regions 1 and 3: where a root can hold the meniscus to the tibia, not
  the femoral surface) and the horn-root ligaments of ``meniscal_ligaments.json``
  (smith2019's AHORN / PHORN Blankevoort 1991 bundles, tibial and meniscal points, k in N
  per unit strain, slack length) with the mesh node nearest each meniscal point.
  Donahue et al. 2002 tie the horns to the tibia by linear springs; the stiffness the
  citing studies quote for them is `DONAHUE_HORN_N_PER_MM` (not read in the paper).

`hoop_force` gives the hoop stress along the arc and the hoop force through cross-sections
of a solved stress field. Units: mm, N, MPa; the tibia frame of the data set.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.bodies.volume import tetrahedralize
from fecheck.model.menisci import menisci_dir, read_volume
from fecheck.scene import Scene
from fecheck.scene.constants import COMPARTMENTS
from fecheck.scene.packaged import PACKAGE_PREFIX, data_dir
from fecheck.scene.surfaces import read_surface
from geometry.cache import cached_build, content_digest
from geometry.mesh import TetMesh, TriMesh, edge_table
from geometry.subdivide import subdivide

DEFAULT_SIZE_MM = 1.25
"""Target edge of the meniscus tetrahedra, mm (proposed scene key ``menisci.fe_size_mm``):
the packaged surfaces' own edges are 0.9-1.0 mm (median), kept below it."""
LABEL_TOLERANCE_MM = 0.3
"""Largest distance from a boundary face's centroid to an articular surface for the face
to be that surface's, mm (the surfaces lie on the volume within 0.22 mm)."""
SUPERIOR, INFERIOR, WALL = 0, 1, 2
"""Boundary face labels: femur-facing, tibia-facing, free rim / inner wall / horn end."""
REGIONS = {1: "1_anterior", 2: "2_middle", 3: "3_posterior"}
"""Region number -> file suffix of the packaged regions (1 anterior horn ... 3 posterior)."""
HORNS = {"anterior": (1, "AHORN"), "posterior": (3, "PHORN")}
"""Horn -> (its region, the group of its root ligaments in meniscal_ligaments.json)."""
DONAHUE_HORN_N_PER_MM = 2000.0
"""Stiffness of each meniscal root spring, N/mm, as quoted for Donahue et al. 2002 (J Biomech
Eng 124:273) and the models after it by a citing study ("Sensitivity of the tibio-femoral
response ...", excerpted by scite.ai, the source of `fecheck.fe.material.anisotropy.MENISCUS`): "the
anterior and posterior meniscal roots ... linear springs with spring constants of 2000
N/mm". Not read in the paper, which could not be opened: how many springs share it is not
checked."""
_NORMAL_COS = 0.5
"""Least cosine between a labelled face's normal and its articular surface's (60 deg)."""
_FOLD_COS = math.cos(math.radians(150.0))
"""Neighbouring faces whose normals are more than 150 deg apart form a fold (`unfold`)."""
_CACHE_VERSION = 1


@dataclass(frozen=True)
class HornLigament:
    """One horn-root ligament bundle: tibial and meniscal points (mm), Blankevoort 1991
    stiffness (N per unit strain), slack length (mm), transition strain, and the mesh node
    nearest the meniscal point with its distance (mm)."""

    name: str
    tibia_mm: tuple[float, float, float]
    meniscus_mm: tuple[float, float, float]
    stiffness_N: float
    slack_length_mm: float
    transition_strain: float
    node: int
    node_distance_mm: float

    @property
    def stiffness_N_per_mm(self) -> float:
        """Linear-region stiffness k / l0, N/mm."""
        return self.stiffness_N / self.slack_length_mm


@dataclass(frozen=True, eq=False)
class Horn:
    """A horn: its attachment nodes (indices into the tet mesh's points) and its root
    ligaments."""

    name: str
    nodes: np.ndarray
    ligaments: tuple[HornLigament, ...]

    @property
    def direction(self) -> np.ndarray:
        """(3,) unit direction of the root: from its bundles' mean tibial point to their
        mean meniscal point (`FecheckError` without bundles)."""
        if not self.ligaments:
            raise FecheckError(f"the {self.name} horn has no root bundle in "
                               "meniscal_ligaments.json: its root's direction is unknown")
        d = (np.mean([b.meniscus_mm for b in self.ligaments], axis=0)
             - np.mean([b.tibia_mm for b in self.ligaments], axis=0))
        return d / np.linalg.norm(d)


@dataclass(frozen=True, eq=False)
class Centreline:
    """A meniscus's centreline sampled densely: points (k, 3) mm, unit tangents (k, 3)
    from the anterior towards the posterior horn, arc coordinate (k,) (0 at the anterior
    tip, 1 at the posterior one; beyond them on the straight extensions)."""

    points: np.ndarray
    tangents: np.ndarray
    arc: np.ndarray

    def closest(self, x: np.ndarray) -> np.ndarray:
        """(n,) index of the centreline sample closest to each point `x` (n, 3), mm."""
        from scipy.spatial import cKDTree

        return cKDTree(self.points).query(np.asarray(x, dtype=float))[1]

    def at(self, arc: float) -> tuple[np.ndarray, np.ndarray]:
        """(point (3,), unit tangent (3,)) at arc coordinate `arc`."""
        k = int(np.argmin(np.abs(self.arc - arc)))
        return self.points[k], self.tangents[k]


@dataclass(frozen=True, eq=False)
class MeniscusSolid:
    """A meniscus as an FE solid (module docstring): P1 tet mesh (mm, tibia frame) whose
    first points are the boundary's; boundary triangles (m, 3) outward; per boundary face
    its label (`SUPERIOR`, `INFERIOR`, `WALL`) and region (1-3); per element the unit fibre
    direction (nel, 3) and arc coordinate (nel,); the centreline; the horns; mesh quality
    (`tet_quality`) with the STL's volume, the vertices `unfold` moved and the mesh's
    seconds (built, or read from the cache)."""

    side: str
    mesh: TetMesh
    boundary: np.ndarray
    face_label: np.ndarray
    face_region: np.ndarray
    fibre: np.ndarray
    arc: np.ndarray
    centreline: Centreline
    horns: dict[str, Horn]
    quality: dict[str, float] = field(default_factory=dict)

    @property
    def boundary_mesh(self) -> TriMesh:
        """The boundary triangles on the mesh's points."""
        return TriMesh(self.mesh.points, self.boundary)

    def area_mm2(self, label: int) -> float:
        """Area of the boundary faces with `label`, mm²."""
        return float(self.boundary_mesh.face_areas[self.face_label == label].sum())

    def faces(self, label: int) -> np.ndarray:
        """(k, 3) boundary triangles with `label`."""
        return self.boundary[self.face_label == label]


def _folder(source: Scene | str | Path) -> Path:
    if isinstance(source, Scene):
        return menisci_dir(source)
    if str(source).startswith(PACKAGE_PREFIX):
        return data_dir(str(source), "menisci.dir")
    folder = Path(source).expanduser()
    if not folder.is_dir():
        raise FecheckError(f"menisci folder {folder} not found: give the smith2019_menisci "
                           "folder or 'fecheck:knee/smith2019_menisci'")
    return folder


def _read(folder: Path, name: str, move=None) -> TriMesh:
    """The surface `name` of `folder`, moved with the meniscus's shape (`move`: a
    `fecheck.model.menisci.Shape`; None: as shipped)."""
    path = folder / name
    if not path.is_file():
        raise FecheckError(f"{path}: missing; the meniscus solid needs the data set's "
                           "articular surfaces and regions (smith2019_menisci, as packaged)")
    return read_surface(path) if move is None else move.sheet(read_surface(path))


def meniscus_solid(source: Scene | str | Path, side: str, size_mm: float = DEFAULT_SIZE_MM,
                   *, tolerance_mm: float = LABEL_TOLERANCE_MM) -> MeniscusSolid:
    """The `side` meniscus of the menisci folder `source` (a scene's ``menisci.dir``, a
    ``fecheck:`` name or a folder) as an FE solid with tetrahedra of about `size_mm`
    (module docstring). Raises `FecheckError` for an unknown side, a size outside
    0.2-5 mm or a missing file."""
    if side not in COMPARTMENTS:
        raise FecheckError(f"meniscus side {side!r}: give 'medial' or 'lateral'")
    if not 0.2 <= size_mm <= 5.0:
        raise FecheckError(f"meniscus tetrahedra of {size_mm} mm: give a size from 0.2 to "
                           "5 mm (about 1-1.5 mm resolves a 5 mm high meniscus)")
    folder = _folder(source)
    volume = read_volume(folder, side)
    move = cut = None
    if isinstance(source, Scene):
        from fecheck.model.menisci import shapes

        move = shapes(source, [side])[side]
        cut = move.cut
        volume = TriMesh(move.fit(volume.points) if move.fit is not None else volume.points,
                         volume.faces)
    stem = f"smith2019_R_meniscus_{side}"
    articular = {lab: _read(folder, f"{stem}_{face}.stl", move)
                 for lab, face in ((SUPERIOR, "superior"), (INFERIOR, "inferior"))}
    regions = {(face, r): _read(folder, f"regions/{stem}_{face}_{suffix}.stl", move)
               for face in ("superior", "inferior") for r, suffix in REGIONS.items()}
    t0 = time.perf_counter()
    mesh, moved = solid_mesh(volume, size_mm, f"{folder / stem}.stl")
    if cut is not None:
        mesh = resect(mesh, cut.inner)
    t_mesh = time.perf_counter() - t0
    boundary = mesh.boundaries["boundary"]
    surface = TriMesh(mesh.points, boundary)
    label = label_faces(surface, articular, tolerance_mm)
    region = nearest_region(surface, regions)
    line, fibre, arc = centreline_fibres(mesh, boundary)
    horns = horn_attachments(mesh, boundary, label, region,
                             folder / "meniscal_ligaments.json", side, move)
    quality = tet_quality(mesh) | {"seconds": t_mesh, "unfolded_vertices": float(moved),
                                   "stl_volume_mm3": volume.signed_volume}
    return MeniscusSolid(side, mesh, boundary, label, region, fibre, arc, line, horns,
                         quality)


def resect(mesh: TetMesh, inner) -> TetMesh:
    """`mesh` without the tetrahedra whose centroid `inner` ((n, 3) points → (n,) bool)
    marks (a partial meniscectomy: `fecheck.model.menisci_shape.PartialMap.inner`), its
    points compacted and its boundary (``boundaries["boundary"]``, outward) the faces
    of one remaining tetrahedron each. `FecheckError` if nothing is left."""
    tets = mesh.tets[~inner(mesh.points[mesh.tets].mean(axis=1))]
    if not len(tets):
        raise FecheckError("the partial meniscectomy leaves no tetrahedron of the meniscus")
    used = np.unique(tets)
    index = np.full(len(mesh.points), -1)
    index[used] = np.arange(len(used))
    tets = index[tets]
    points = mesh.points[used]
    p = points[tets]
    negative = np.einsum("ij,ij->i", p[:, 1] - p[:, 0],
                         np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0])) < 0
    tets[negative] = tets[negative][:, [0, 2, 1, 3]]
    faces = tets[:, [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]].reshape(-1, 3)
    _, first, count = np.unique(np.sort(faces, axis=1), axis=0, return_index=True,
                                return_counts=True)
    return TetMesh(points, tets, {"boundary": faces[first[count == 1]]})


def unfold(surface: TriMesh) -> tuple[TriMesh, int]:
    """(`surface` without folds, vertices moved): the vertices of every edge whose two
    faces' normals are more than 150 deg apart go to the mean of their neighbours,
    repeated until none is left (at most 10 times); `FecheckError` if one stays."""
    points = surface.points.copy()
    table = edge_table(surface.faces)
    pairs = table.counts == 2
    first = table.order[table.start[pairs]] // 3
    second = table.order[table.start[pairs] + 1] // 3
    ends = table.edges[pairs]
    e = table.edges
    degree = np.bincount(e.ravel(), minlength=len(points))
    moved: set[int] = set()
    for _ in range(10):
        n = TriMesh(points, surface.faces).face_normals
        bad = np.einsum("ij,ij->i", n[first], n[second]) < _FOLD_COS
        if not bad.any():
            return TriMesh(points, surface.faces, surface.regions), len(moved)
        verts = np.unique(ends[bad])
        mean = np.zeros_like(points)
        np.add.at(mean, e[:, 0], points[e[:, 1]])
        np.add.at(mean, e[:, 1], points[e[:, 0]])
        points[verts] = mean[verts] / degree[verts, None]
        moved.update(verts.tolist())
    where = ", ".join(f"{v:.1f}" for v in points[ends[bad][0]].mean(axis=0))
    raise FecheckError(f"meniscus volume: a fold of its surface at ({where}) mm does not "
                       "smooth out; repair the STL there")


def solid_mesh(volume: TriMesh, size_mm: float, name: str) -> tuple[TetMesh, int]:
    """(P1 tet mesh of the closed `volume`, vertices `unfold` moved): the boundary the
    unfolded surface split in four as often as brings its median edge nearest `size_mm`
    (log scale), interior edges at most `size_mm`, Netgen-optimised; its boundary triangles in
    ``boundaries["boundary"]``. Cached by the surface's content and the size."""
    surface, moved = unfold(volume)
    edges = np.linalg.norm(np.diff(surface.points[surface.edges_unique], axis=1)[:, 0],
                           axis=1)
    levels = max(0, round(math.log2(float(np.median(edges)) / size_mm)))

    def build() -> TetMesh:
        fine, _ = subdivide(surface, levels)
        mesh = tetrahedralize(fine, name, {"Mesh.MeshSizeMax": size_mm,
                                           "Mesh.Optimize": 1, "Mesh.OptimizeNetgen": 1})
        return TetMesh(mesh.points, mesh.tets, {"boundary": fine.faces})

    params = {"surface": content_digest([surface]), "size_mm": size_mm, "levels": levels}
    return cached_build("meniscus-solid", params, build, version=_CACHE_VERSION), moved


def tet_quality(mesh: TetMesh) -> dict[str, float]:
    """Element quality: the smallest dihedral angle (deg), the smallest radius ratio
    γ = 3 r_in / r_circ (1 for a regular tetrahedron, Gmsh's "gamma"-like measure), the
    share of elements under 10 deg, the counts and the volume (mm³)."""
    p = mesh.points[mesh.tets]
    pairs = ((0, 1, 2, 3), (0, 2, 1, 3), (0, 3, 1, 2), (1, 2, 0, 3), (1, 3, 0, 2),
             (2, 3, 0, 1))
    angles = []
    for i, j, k, m in pairs:
        e = p[:, j] - p[:, i]
        a = np.cross(e, p[:, k] - p[:, i])
        b = np.cross(e, p[:, m] - p[:, i])
        c = np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) *
                                           np.linalg.norm(b, axis=1))
        angles.append(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
    dihedral = np.min(angles, axis=0)
    vol = np.abs(mesh.tet_volumes)
    faces = np.stack([p[:, [1, 2, 3]], p[:, [0, 2, 3]], p[:, [0, 1, 3]], p[:, [0, 1, 2]]], 1)
    area = 0.5 * np.linalg.norm(np.cross(faces[:, :, 1] - faces[:, :, 0],
                                         faces[:, :, 2] - faces[:, :, 0]), axis=2).sum(1)
    r_in = 3.0 * vol / area
    d = p[:, 1:] - p[:, :1]                                          # circumradius
    rhs = 0.5 * np.einsum("nij,nij->ni", d, d)
    centre = np.linalg.solve(d, rhs[..., None])[..., 0]
    r_circ = np.linalg.norm(centre, axis=1)
    return {"tets": float(len(mesh.tets)), "nodes": float(len(mesh.points)),
            "volume_mm3": float(vol.sum()), "min_dihedral_deg": float(dihedral.min()),
            "share_dihedral_below_10_deg": float(np.mean(dihedral < 10.0)),
            "min_gamma": float((3.0 * r_in / r_circ).min())}


def label_faces(surface: TriMesh, articular: dict[int, TriMesh], tolerance_mm: float
                ) -> np.ndarray:
    """(m,) `SUPERIOR`, `INFERIOR` or `WALL` per face of `surface` (module docstring);
    `articular`: label -> that articular surface. A face is the surface's when its
    centroid lies within `tolerance_mm` of it, over it (the offset from the closest point
    within 30 deg of that face's normal, or under 0.01 mm: not past its rim) and its
    normal within 60 deg of the surface's there; the nearer surface wins."""
    import igl

    best = np.full(surface.n_faces, np.inf)
    label = np.full(surface.n_faces, WALL)
    x = np.ascontiguousarray(surface.face_centroids)
    for lab, sheet in articular.items():
        tree = igl.AABB()
        tree.init(sheet.points, sheet.faces)
        sq, face, closest = tree.squared_distance(sheet.points, sheet.faces, x)
        dist, normal = np.sqrt(sq), sheet.face_normals[face]
        along = np.abs(np.einsum("ij,ij->i", x - closest, normal))
        aside = np.sqrt(np.maximum(sq - along ** 2, 0.0))
        facing = np.einsum("ij,ij->i", surface.face_normals, normal)
        take = ((dist <= tolerance_mm) & (aside <= 0.5 * dist + 0.01)
                & (facing >= _NORMAL_COS) & (dist < best))
        label[take], best[take] = lab, dist[take]
    return label


def nearest_region(surface: TriMesh, regions: dict[tuple[str, int], TriMesh]) -> np.ndarray:
    """(m,) the region number (1-3) of the packaged region nearest each face centroid."""
    from geometry.distance import closest_distance

    keys = list(regions)
    dist = np.stack([closest_distance(surface.face_centroids, regions[k])[0] for k in keys])
    return np.array([k[1] for k in keys])[np.argmin(dist, axis=0)]


def _opening_angles(xy: np.ndarray, centre: np.ndarray, angles_of: np.ndarray
                    ) -> tuple[np.ndarray, float, float]:
    """(angles (rad) of points `angles_of` about `centre`, measured counter-clockwise from
    the edge of the largest empty sector of the points `xy` (the C's opening) round to the
    other edge; the span of `xy` in that measure; the start edge's own angle)."""
    a = np.sort(np.arctan2(xy[:, 1] - centre[1], xy[:, 0] - centre[0]))
    gaps = np.diff(np.r_[a, a[0] + 2 * np.pi])
    k = int(np.argmax(gaps))
    start = a[(k + 1) % len(a)]
    rel = angles_of - centre
    phi = np.mod(np.arctan2(rel[:, 1], rel[:, 0]) - start, 2 * np.pi)
    return phi, float(2 * np.pi - gaps[k]), float(start)


def centreline_fibres(mesh: TetMesh, boundary: np.ndarray, bins: int = 24,
                      axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
                      ) -> tuple[Centreline, np.ndarray, np.ndarray]:
    """(centreline, fibre (nel, 3), arc (nel,)) of a C-shaped solid (module docstring):
    `bins` angular bins about the circle fitted to the boundary's footprint in the plane
    normal to `axis`."""
    from numpy.polynomial import Chebyshev

    ez = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    ex = np.cross(ez, [1.0, 0.0, 0.0] if abs(ez[0]) < 0.9 else [0.0, 1.0, 0.0])
    ex /= np.linalg.norm(ex)
    plane = np.column_stack([ex, np.cross(ez, ex)])                 # (3, 2)
    nodes = mesh.points[np.unique(boundary)]
    xy = nodes @ plane
    A = np.column_stack([2 * xy, np.ones(len(xy))])                 # Kasa circle fit
    centre = np.linalg.lstsq(A, (xy ** 2).sum(axis=1), rcond=None)[0][:2]
    centroids = mesh.points[mesh.tets].mean(axis=1)
    vol = np.abs(mesh.tet_volumes)
    phi, span, start = _opening_angles(xy, centre, centroids @ plane)
    which = np.minimum((phi / span * bins).astype(int), bins - 1)
    weight = np.bincount(which, weights=vol, minlength=bins)
    keep = weight > 0
    if keep.sum() < 8:
        raise FecheckError("meniscus solid: too few elements along its arc to fit a "
                           "centreline; lower the element size")
    polar = np.column_stack([phi, np.linalg.norm(centroids @ plane - centre, axis=1),
                             centroids @ ez])
    mean = np.stack([np.bincount(which, weights=vol * v, minlength=bins) for v in polar.T],
                    axis=1)[keep] / weight[keep, None]
    fits = [Chebyshev.fit(mean[:, 0], mean[:, i], min(5, keep.sum() - 3),
                          domain=[0.0, span], w=np.sqrt(weight[keep])) for i in (1, 2)]
    u = np.linspace(0.0, span, 2001)
    r, dr, h, dh = fits[0](u), fits[0].deriv()(u), fits[1](u), fits[1].deriv()(u)
    cos, sin = np.cos(u + start), np.sin(u + start)
    pts = (np.column_stack([centre[0] + r * cos, centre[1] + r * sin]) @ plane.T
           + h[:, None] * ez)
    tan = (np.column_stack([dr * cos - r * sin, dr * sin + r * cos]) @ plane.T
           + dh[:, None] * ez)
    tan /= np.linalg.norm(tan, axis=1, keepdims=True)
    step = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).mean())
    reach = 2.0 * step * (len(u) - 1) / bins                        # two bins straight on
    ext = np.arange(1, int(reach / step) + 1)[:, None] * step
    pts = np.vstack([pts[0] - ext[::-1] * tan[0], pts, pts[-1] + ext * tan[-1]])
    tan = np.vstack([np.repeat(tan[:1], len(ext), 0), tan, np.repeat(tan[-1:], len(ext), 0)])
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))]
    line = Centreline(pts, tan, s)
    s_nodes = s[line.closest(nodes)]
    lo, hi = s_nodes.min(), s_nodes.max()
    end = line.closest(nodes[[np.argmin(s_nodes), np.argmax(s_nodes)]])
    if pts[end[0], 1] < pts[end[1], 1]:             # start at the anterior (larger y) tip
        lo, hi = hi, lo
        tan = -tan
    line = Centreline(pts, tan, (s - lo) / (hi - lo))
    k = line.closest(centroids)
    return line, tan[k], line.arc[k]


def horn_attachments(mesh: TetMesh, boundary: np.ndarray, label: np.ndarray,
                     region: np.ndarray, ligaments: Path, side: str, move=None
                     ) -> dict[str, Horn]:
    """{"anterior", "posterior"}: the `Horn` of each (module docstring) from the faces'
    labels and regions and the ligaments file (meniscal points moved by `move`, the
    meniscus's shape, when given)."""
    from scipy.spatial import cKDTree

    if not ligaments.is_file():
        raise FecheckError(f"{ligaments}: missing; the meniscus solid reads its horn-root "
                           "ligaments there")
    items = json.loads(ligaments.read_text(encoding="utf-8"))["ligaments"]
    tree = cKDTree(mesh.points)
    out = {}
    for horn, (reg, group) in HORNS.items():
        nodes = np.unique(boundary[(region == reg) & (label != SUPERIOR)])
        bundles = []
        for item in items:
            if item.get("meniscus") != side or item.get("group") != group:
                continue
            tibia, men = (tuple(float(v) for v in x) for x in item["points_mm"])
            if move is not None:
                men = tuple(float(v) for v in move(np.array([men]))[0])
            dist, node = tree.query(men)
            p = item["parameters"]
            bundles.append(HornLigament(
                item["name"], tibia, men, float(p["linear_stiffness"]["value"]),
                1000.0 * float(p["slack_length"]["value"]),
                float(p["transition_strain"]["value"]), int(node), float(dist)))
        out[horn] = Horn(horn, nodes, tuple(bundles))
    return out


@dataclass(frozen=True)
class HoopResult:
    """Hoop stress along the arc (bin centres (b,), volume-mean σ_θθ (b,) MPa) and the
    hoop force (N) and section area (mm²) through cross-sections at arc coordinates."""

    arc: np.ndarray
    hoop_stress_MPa: np.ndarray
    section_arc: np.ndarray
    force_N: np.ndarray
    section_area_mm2: np.ndarray


def section(mesh: TetMesh, point: np.ndarray, normal: np.ndarray, elements: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """(element indices, areas mm²) of the plane through `point` with unit `normal`
    across the tetrahedra `elements` (indices): the area of each one's plane section."""
    p = mesh.points[mesh.tets[elements]]                            # (n, 4, 3)
    d = (p - point) @ normal
    above = d > 0
    k = above.sum(axis=1)
    cut = (k > 0) & (k < 4)
    p, d, above, k = p[cut], d[cut], above[cut], k[cut]
    order = np.argsort(~above, axis=1, kind="stable")               # above first
    p = np.take_along_axis(p, order[..., None], axis=1)
    d = np.take_along_axis(d, order, axis=1)

    def cross(i, j, rows):                                          # edge i-j meets plane
        t = d[rows, i] / (d[rows, i] - d[rows, j])
        return p[rows, i] + t[:, None] * (p[rows, j] - p[rows, i])

    area = np.zeros(len(p))
    for rows, edges in ((k == 1, ((0, 1), (0, 2), (0, 3))), (k == 3, ((3, 0), (3, 1), (3, 2)))):
        q = [cross(*e, rows) for e in edges]
        area[rows] = 0.5 * np.linalg.norm(np.cross(q[1] - q[0], q[2] - q[0]), axis=1)
    q = [cross(*e, k == 2) for e in ((0, 2), (0, 3), (1, 3), (1, 2))]
    area[k == 2] = 0.5 * np.linalg.norm(np.cross(q[2] - q[0], q[3] - q[1]), axis=1)
    return np.asarray(elements)[cut], area


def hoop_force(solid: MeniscusSolid, sigma: np.ndarray,
               arcs: tuple[float, ...] = (0.25, 0.5, 0.75), bins: int = 20,
               reach: float = 0.2) -> HoopResult:
    """Hoop stress and force of the per-element stress `sigma` (nel, 3, 3) MPa.

    The hoop stress σ_θθ = d·σ·d (d the element's fibre) is averaged over `bins` equal
    arc bins (volume-weighted); the hoop force at arc coordinate s is ∫ t·σ·t dA over the
    plane through the centreline at s normal to its tangent t, cut through the elements
    within `reach` of s in arc coordinate (so not through the C's other arm); constant
    stress per element. `FecheckError` for a stress of the wrong shape or not finite, or
    an arc coordinate outside (0, 1)."""
    sigma = np.asarray(sigma, dtype=float)
    nel = len(solid.mesh.tets)
    if sigma.shape != (nel, 3, 3) or not np.isfinite(sigma).all():
        raise FecheckError(f"hoop force: need one finite stress tensor per element "
                           f"({nel}, 3, 3) MPa, got shape {sigma.shape}")
    s = np.asarray(arcs, dtype=float)
    if ((s <= 0) | (s >= 1)).any():
        raise FecheckError(f"hoop force: section arc coordinates {s.tolist()} must lie "
                           "strictly between 0 (anterior tip) and 1 (posterior tip)")
    vol = np.abs(solid.mesh.tet_volumes)
    hoop = np.einsum("ni,nij,nj->n", solid.fibre, sigma, solid.fibre)
    which = np.clip((solid.arc * bins).astype(int), 0, bins - 1)
    weight = np.bincount(which, weights=vol, minlength=bins)
    mean = np.bincount(which, weights=vol * hoop, minlength=bins) / np.where(
        weight > 0, weight, np.nan)
    force, area = np.zeros(len(s)), np.zeros(len(s))
    for i, arc in enumerate(s):
        point, t = solid.centreline.at(arc)
        near = np.flatnonzero(np.abs(solid.arc - arc) < reach)
        elements, a = section(solid.mesh, point, t, near)
        force[i] = float(a @ np.einsum("i,nij,j->n", t, sigma[elements], t))
        area[i] = float(a.sum())
    return HoopResult((np.arange(bins) + 0.5) / bins, mean, s, force, area)
