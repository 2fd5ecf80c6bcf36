"""The tibial cartilage or insert as a closed solid in the FE: tetrahedralized, base
fixed, walls free.

A closed outward triangle surface (``geometry.tibia_solid``, `fecheck.scene.tibia_solid`;
each closed piece its own volume) is handed to Gmsh as a discrete surface and its volume
meshed in tetrahedra (``geo.addSurfaceLoop`` + ``addVolume``): the boundary triangles are
kept as given, so the articular face is the user's (or, with ``fe.refine``, theirs split
in four per level), and the interior sizes are interpolated from the boundary's (a fine
articular face over a coarse base grades the mesh by itself). Small-strain elasticity on
quadratic tetrahedra with straight edges (`fecheck.fe.bodies.solid.p2_elasticity`); every node
of the base faces (outward normal within ``fe.solid_base_deg`` of -z, away from the
femur) is fixed, the walls are free. On the articular face contact acts at the vertices
along their normals, the midside normal displacements tied to their end vertices' as on
the extruded layer (`fecheck.fe.bodies.solid`), so both paths press the same kind of surface.

One solid carries both compartments when it is one piece (their `LayerSolid` views share
one stiffness matrix, which `fecheck.fe.solve.joint` condenses once, coupled).

Units: mm, N, MPa; the solid lives in the tibia frame.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from fecheck.errors import FecheckError
from fecheck.fe.bodies.solid import (
    LayerSolid,
    check_material,
    edge_lookup,
    p2_elasticity,
    tie_matrix,
)
from fecheck.fe.pressure.recovery import tributary_areas
from geometry.distance import closest_distance, ray_hits
from geometry.mesh import TetMesh, TriMesh, components
from geometry.subdivide import subdivide

RIM_OVERHANG_MM = 0.5
"""A tibial sheet's rim may overhang its closed solid by up to this, mm: an implant's insert
sheet and solid exported apart differ by up to 0.25 mm at the rim; beyond it the sheet is
refused (`solid_thickness`)."""


@dataclass(frozen=True, eq=False)
class TibiaSolid:
    """A closed tibial solid: its outward surface (mm, tibia frame), the face indices of
    each compartment's articular face, and its file name."""

    surface: TriMesh
    articular: dict[str, np.ndarray]
    name: str


def tetrahedralize(surface: TriMesh, name: str, options: dict[str, float] | None = None
                   ) -> TetMesh:
    """Linear tetrahedra filling the closed outward `surface` (every closed piece its own
    volume); the surface's vertices are the mesh's first points, in order. `options`:
    Gmsh options set before meshing (e.g. ``{"Mesh.MeshSizeMax": 1.25}``).

    Raises `FecheckError` naming `name` when Gmsh cannot fill it (a self-intersecting or
    inside-out surface) or returns an inverted tetrahedron.
    """
    from geometry.gmsh_session import gmsh_session

    pieces = components(surface)
    with gmsh_session("tibia-solid") as gmsh:
        for k, faces in enumerate(pieces, start=1):
            used = np.unique(surface.faces[faces])
            gmsh.model.addDiscreteEntity(2, k)
            gmsh.model.mesh.addNodes(2, k, used + 1, surface.points[used].ravel())
            gmsh.model.mesh.addElementsByType(k, 2, [], (surface.faces[faces] + 1).ravel())
        for k in range(1, len(pieces) + 1):
            gmsh.model.geo.addVolume([gmsh.model.geo.addSurfaceLoop([k])])
        gmsh.model.geo.synchronize()
        for key, value in (options or {}).items():
            gmsh.option.setNumber(key, value)
        try:
            gmsh.model.mesh.generate(3)
        except Exception as err:       # gmsh raises a bare Exception with its log line
            raise FecheckError(f"{name}: Gmsh could not mesh the volume of the closed "
                               f"surface ({str(err).splitlines()[0]}); check that it does "
                               "not intersect itself") from err
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, tet_nodes = gmsh.model.mesh.getElementsByType(4)
    tags = tags.astype(np.int64)
    index = np.full(tags.max() + 1, -1, dtype=np.int64)
    index[np.sort(tags)] = np.arange(len(tags))
    points = np.empty((len(tags), 3))
    points[index[tags]] = coords.reshape(-1, 3)
    tets = index[tet_nodes.astype(np.int64)].reshape(-1, 4)
    if len(tets) == 0 or not np.allclose(points[:surface.n_points], surface.points):
        raise FecheckError(f"{name}: Gmsh did not fill the closed surface with tetrahedra; "
                           "check that it does not intersect itself")
    mesh = TetMesh(points, tets)
    if (mesh.tet_volumes <= 0).any():
        raise FecheckError(f"{name}: the tetrahedral mesh has "
                           f"{int((mesh.tet_volumes <= 0).sum())} inverted elements; check "
                           "that the closed surface does not intersect itself")
    return mesh


def base_faces(surface: TriMesh, articular: np.ndarray, base_deg: float, name: str
               ) -> np.ndarray:
    """Face indices of the fixed base: outward normals within `base_deg` of -z, not
    articular; `FecheckError` when a closed piece has none (it would float)."""
    down = surface.face_normals[:, 2] <= -math.cos(math.radians(base_deg))
    down[articular] = False
    for piece in components(surface):
        if not down[piece].any():
            low = surface.points[np.unique(surface.faces[piece])][:, 2].min()
            raise FecheckError(f"{name}: a closed piece of the tibial solid (lowest at z = "
                               f"{low:.1f} mm) has no face whose normal is within "
                               f"fe.solid_base_deg = {base_deg:g} deg of -z, so nothing fixes "
                               "it: raise fe.solid_base_deg or check geometry.rotation_deg")
    return np.flatnonzero(down)


@dataclass(frozen=True, eq=False)
class SolidMesh:
    """A closed tibial solid meshed: its surface split in four `refine` times (mm), each
    split face's parent face, and the linear tetrahedra filling it."""

    surface: TriMesh
    parent: np.ndarray
    tets: TetMesh

    @property
    def n_dofs(self) -> int:
        """Dofs of its quadratic (P2) tetrahedra before the base is fixed: three per
        vertex and per edge."""
        t = self.tets.tets
        pairs = np.sort(t[:, [0, 1, 0, 2, 0, 3, 1, 2, 1, 3, 2, 3]].reshape(-1, 2), axis=1)
        edges = np.unique(pairs[:, 0].astype(np.int64) * len(self.tets.points) + pairs[:, 1])
        return 3 * (len(self.tets.points) + len(edges))

    def kept_dofs(self, solid: TibiaSolid, base_deg: float) -> int:
        """The dofs `solid_layers` keeps: `n_dofs` less the base's nodes (vertices and
        edge midpoints, fixed) and one per articular edge (its midside node's normal
        displacement, tied to its ends')."""
        every = np.flatnonzero(np.isin(self.parent,
                                       np.concatenate(list(solid.articular.values()))))
        base = self.surface.faces[base_faces(self.surface, every, base_deg, solid.name)]
        fixed = len(np.unique(base)) + len(TriMesh(self.surface.points, base).edges_unique)
        tied = len(TriMesh(self.surface.points, self.surface.faces[every]).edges_unique)
        return self.n_dofs - 3 * fixed - tied


def mesh_solid(solid: TibiaSolid, refine: int = 0) -> SolidMesh:
    """`solid`'s surface split in four `refine` times and its volume tetrahedralized
    (`tetrahedralize`): the cheap first step of `solid_layers`, which the size guard
    counts before anything is assembled."""
    surface, parent = subdivide(solid.surface, refine)
    return SolidMesh(surface, parent, tetrahedralize(surface, solid.name))


def solid_layers(solid: TibiaSolid, youngs_MPa: float, poisson: float, *,
                 base_deg: float = 45.0, refine: int = 0,
                 formulation: str = "displacement",
                 meshed: SolidMesh | None = None) -> dict[str, LayerSolid]:
    """{compartment: the assembled solid seen from that compartment's articular face}
    (module docstring); all views share one stiffness matrix; `formulation` as in
    `fecheck.fe.bodies.solid.p2_elasticity`; `meshed`: `mesh_solid(solid, refine)` when already
    made."""
    check_material(youngs_MPa, poisson)
    timing = {}
    t0 = time.perf_counter()
    meshed = meshed or mesh_solid(solid, refine)
    surface, parent, tets = meshed.surface, meshed.parent, meshed.tets
    articular = {c: np.flatnonzero(np.isin(parent, f)) for c, f in solid.articular.items()}
    every = np.concatenate(list(articular.values()))
    fixed_faces = surface.faces[base_faces(surface, every, base_deg, solid.name)]
    timing["mesh"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    mesh, basis, K = p2_elasticity(tets, youngs_MPa, poisson, formulation=formulation)
    timing["assemble"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    find_edge = edge_lookup(mesh.edges, mesh.p.shape[1])
    base_edges = TriMesh(surface.points, fixed_faces).edges_unique
    fixed = np.concatenate([basis.nodal_dofs[:, np.unique(fixed_faces)].ravel(),
                            basis.edge_dofs[:, find_edge(*base_edges.T)].ravel()])
    top = surface.faces[every]
    top_normals = np.zeros_like(surface.points)
    top_normals[np.unique(top)] = _vertex_normals(surface.points, top)[np.unique(top)]
    top_edges = TriMesh(surface.points, top).edges_unique
    edge_normal = top_normals[top_edges[:, 0]] + top_normals[top_edges[:, 1]]
    edge_normal /= np.linalg.norm(edge_normal, axis=1, keepdims=True)
    mid_dofs = basis.edge_dofs[:, find_edge(*top_edges.T)].T
    end_dofs = basis.nodal_dofs[:, top_edges.ravel()].T.reshape(-1, 2, 3)
    T, kept = tie_matrix(basis.N, fixed, mid_dofs, end_dofs, edge_normal)
    K_red = (T.T @ K @ T).tocsc()
    position = np.full(basis.N, -1)
    position[kept] = np.arange(len(kept))
    timing["reduce"] = time.perf_counter() - t0
    out = {}
    for c, faces in articular.items():
        used, inverse = np.unique(surface.faces[faces], return_inverse=True)
        face_view = TriMesh(surface.points[used], inverse.reshape(-1, 3))
        dofs = basis.nodal_dofs[:, used].T                                   # (s, 3)
        if (position[dofs] < 0).any():
            where = surface.points[used[(position[dofs] < 0).any(axis=1)][0]]
            raise FecheckError(f"{solid.name}: the {c} articular face touches the fixed base "
                               f"at ({', '.join(f'{v:.1f}' for v in where)}) mm; lower "
                               "fe.solid_base_deg")
        normals = face_view.vertex_normals
        rows = np.repeat(np.arange(len(used)), 3)
        N_full = sp.csr_matrix((normals.ravel(), (rows, dofs.ravel())),
                               shape=(len(used), basis.N))
        out[c] = LayerSolid(tets, K_red, (N_full @ T).tocsr(), position[dofs], normals,
                            tributary_areas(face_view.points, face_view.faces), face_view,
                            len(kept), basis.N // 3, timing)
    return out


def _vertex_normals(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals of `faces` (zero at unused points)."""
    return TriMesh(points, faces).vertex_normals


def solid_thickness(solid: TibiaSolid, sheet: TriMesh, compartment: str = "") -> np.ndarray:
    """(n,) distance from each sheet vertex along its inward normal to the far side of
    `solid` (its faces off the articular face), mm: the thickness map of the layer
    equivalent to it (each ray starts a thousandth of the way toward the vertex's adjacent
    face centroids, so a vertex on the solid's rim or corner does not run down its wall).

    A rim of the sheet may overhang the solid (the two exported apart): vertices whose ray
    leaves the solid nowhere but which lie within `RIM_OVERHANG_MM` of it take the
    thickness of the nearest vertex over the solid, with a warning naming how many faces
    of the `compartment` sheet, how far and where (the solid FE's articular face has none
    there). `FecheckError` with the place beyond that (the sheet is not on the solid)."""
    far = np.setdiff1d(np.arange(solid.surface.n_faces),
                       np.concatenate(list(solid.articular.values())))
    far_side = TriMesh(solid.surface.points, solid.surface.faces[far])
    n = sheet.vertex_normals
    eps = 1e-6 * float(np.linalg.norm(np.ptp(far_side.points, axis=0)))
    inward = np.zeros_like(sheet.points)          # toward the adjacent faces' centroids
    np.add.at(inward, sheet.faces.ravel(), np.repeat(sheet.face_centroids, 3, axis=0))
    inward = inward / np.bincount(sheet.faces.ravel(), minlength=sheet.n_points)[:, None]
    start = sheet.points + 1e-3 * (inward - sheet.points) - eps * n   # off rims and corners
    dist, _ = ray_hits(start, -n, far_side, facing=-n)
    missed = np.flatnonzero(~np.isfinite(dist))
    if len(missed) == 0:
        return dist + eps
    off = closest_distance(sheet.points[missed], solid.surface)[0]
    where = sheet.points[missed[int(np.argmax(off))]]
    place = ", ".join(f"{v:.1f}" for v in where)
    if off.max() > RIM_OVERHANG_MM:
        raise FecheckError(f"geometry.tibia_solid: a ray down from the sheet geometry.tibia at "
                           f"({place}) mm leaves the solid nowhere, and the sheet lies "
                           f"{off.max():.2f} mm from the solid there (more than "
                           f"{RIM_OVERHANG_MM:g} mm): the sheet does not lie on the solid; "
                           "export both from one model in one frame, or trim the sheet there")
    hit = np.flatnonzero(np.isfinite(dist))
    if len(hit) == 0:
        raise FecheckError("geometry.tibia_solid: no ray down from the sheet geometry.tibia "
                           "meets the solid: the sheet does not lie on the solid")
    nearest = hit[cKDTree(sheet.points[hit]).query(sheet.points[missed])[1]]
    dist[missed] = dist[nearest]
    rim = np.isin(sheet.faces, missed).any(axis=1)
    who = f"the {compartment} sheet" if compartment else "the sheet"
    warnings.warn(f"geometry.tibia_solid: {int(rim.sum())} rim faces of {who} geometry.tibia "
                  f"overhang the solid by up to {off.max():.2f} mm (at most "
                  f"{RIM_OVERHANG_MM:g} mm is taken as the two files' export tolerance; "
                  f"furthest at ({place}) mm): the solid FE has no articular face under them "
                  "(their EF faces take the nearest FE face's pressure) and a layer "
                  "(fe.body = 'layer') takes the thickness of the nearest vertex over the solid",
                  stacklevel=2)
    return dist + eps


def parent_faces(surface: TriMesh, ef_surface: TriMesh) -> np.ndarray:
    """(m,) for each face of `surface` the face of `ef_surface` closest to its centroid
    (how the FE pressure is averaged onto the EF's faces)."""
    return closest_distance(surface.face_centroids, ef_surface)[1]
