"""The ring-meniscus verification case: a known answer for the FE with menisci.

A rigid sphere (radius R, centre on the z axis, touching the layer at the origin before
loading) is pressed with a load F along -z onto a flat elastic layer (thickness h, top
z = 0, bonded to rigid bone at z = -h, free rim at `layer_radius_mm`) and onto a ring
meniscus sitting on the layer: a wedge of revolution from r_i to r_o with a flat
inferior face on z = 0 and a superior face on the sphere lowered by `clearance_mm`
(z = R − √(R² − r²) − c), transversely isotropic with the fibres along the hoop
(`fecheck.fe.material.anisotropy`). Frictionless contact on every interface: sphere–layer (the
centre), sphere–meniscus superior face, meniscus inferior face–layer top. The meniscus
floats vertically: its vertical translation is an unknown with its own equilibrium
(`fecheck.fe.solve.multibody`).

Solved two ways with the same contact core (`fecheck.fe.solve.multibody`):

1. axisymmetric, P2 triangles on (r, z) tensor grids (the layer's as
   `fecheck.fe.reference.axisym`, the meniscus's mapped onto its wedge), uniform `size_mm` out to
   r_o. The meniscus's r nodes are the layer's, so the inferior contact is node to node
   on matching quadratic nodes (consistent loads 1/6, 2/3, 1/6: all positive); on a flat
   interface with small sliding this is the exact discrete pairing, no segment search.
2. 3-D, a quarter model with symmetry planes x = 0 and y = 0 (they remove the ring's
   in-plane rigid modes): both solids meshed by Gmsh as revolved sections (the layer's
   top split at r_i and r_o so its mesh follows the meniscus's rim), quadratic
   tetrahedra, contact at vertices with the midside normal displacement on contact
   faces tied to its edge's ends (as `fecheck.fe.bodies.solid`); the layer's top vertices under
   the meniscus meet its inferior faces by rays (node to surface, `ray_pairs`).

Compared: the load share (force through the meniscus / F), the layer's vertex p_max (the
axisymmetric nodal pressure projected from the consistent loads, `project_pressure`;
3-D: vertex force / tributary area) and the layer's contact area (the region where the
pressure interpolated linearly from its nodes, squared and extrapolated past the last
contact node, is positive: `zero_contour_area` in 3-D and its 1-D counterpart here,
taken separately over the sphere's and the meniscus's candidates so the meniscus rim is
not smeared outward). Units: mm, N, MPa.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.contact.condense import ElasticBody, Pair
from fecheck.fe.material.anisotropy import MENISCUS, TransIso
from fecheck.fe.pressure.recovery import project_pressure
from fecheck.fe.solve.multibody import Indenter, ray_pairs, solve_multibody
from geometry.mesh import TetMesh, TriMesh


@dataclass(frozen=True)
class RingCase:
    """The ring-meniscus problem (module docstring): load N, sphere radius mm, meniscus
    radii and clearance mm, layer thickness and radius mm, layer E (MPa) and ν, the
    meniscus's transversely isotropic constants (fibres along the hoop). With these
    defaults the meniscus carries 47 % of the load (the clearance sets the share: 0.1 mm
    78 %, 0.4 mm 28 %)."""

    load_N: float = 300.0
    radius_mm: float = 25.0
    inner_mm: float = 6.0
    outer_mm: float = 12.0
    clearance_mm: float = 0.3
    thickness_mm: float = 2.0
    layer_radius_mm: float = 18.0
    youngs_MPa: float = 15.0
    poisson: float = 0.4
    meniscus: TransIso | None = field(default=MENISCUS)

    def top(self, r: np.ndarray) -> np.ndarray:
        """Height of the meniscus's superior face at radius r, mm."""
        R = self.radius_mm
        return R - np.sqrt(R * R - np.asarray(r) ** 2) - self.clearance_mm

    def check(self) -> None:
        """`FecheckError` unless the sizes nest: 0 < r_i < r_o < layer radius < R."""
        nested = 0 < self.inner_mm < self.outer_mm < self.layer_radius_mm < self.radius_mm
        if not (nested and self.thickness_mm > 0 and self.clearance_mm >= 0
                and float(self.top(self.inner_mm)) > 0):
            raise FecheckError(f"ring meniscus: need 0 < inner ({self.inner_mm}) < outer "
                               f"({self.outer_mm}) < layer radius ({self.layer_radius_mm}) "
                               f"< sphere radius ({self.radius_mm}) mm, a positive layer "
                               f"thickness and a clearance ({self.clearance_mm} mm) in [0, "
                               "the sphere's height at the inner radius)")


@dataclass(frozen=True)
class RingAnswer:
    """share: meniscus force / load; p_max_MPa: the layer's vertex peak; area_mm2: the
    layer's contact area (whole ring); approach_mm; max_penetration_mm; n_dofs;
    seconds; method."""

    share: float
    p_max_MPa: float
    area_mm2: float
    approach_mm: float
    max_penetration_mm: float
    n_dofs: int
    seconds: float
    method: str


# ----------------------------------------------------------------------------------------
# axisymmetric


def _axis_grid(case: RingCase, size_mm: float) -> np.ndarray:
    """r nodes: uniform `size_mm` to r_o with nodes on r_i and r_o, graded beyond."""
    def uniform(a: float, b: float) -> np.ndarray:
        return np.linspace(a, b, max(int(np.ceil((b - a) / size_mm - 1e-9)), 1) + 1)

    inner = uniform(0.0, case.inner_mm)
    ring = uniform(case.inner_mm, case.outer_mm)
    rim = _growing(case.outer_mm, case.layer_radius_mm, size_mm, 1.15, case.thickness_mm)
    return np.unique(np.concatenate([inner, ring, rim]))


def _growing(start: float, end: float, step: float, ratio: float, max_step: float
             ) -> np.ndarray:
    """start, start + step, ... with steps growing by `ratio` up to `max_step`, to `end`
    (a last step shorter than half the one before is merged into it)."""
    steps = np.minimum(step * ratio ** np.arange(1, 200), max_step)
    x = start + np.concatenate([[0.0], np.cumsum(steps)])
    x = x[x < end - 1e-12]
    if end - x[-1] < 0.5 * (x[-1] - x[-2] if len(x) > 1 else step):
        x = x[:-1]
    return np.append(x, end)


def _line_pressure(r: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Nodal pressure (MPa) on the quadratic line through the sorted nodes r (vertices and
    midpoints alternating, mm) whose consistent loads ∫ φ_i p 2πr dr are `force` (N):
    the mass-matrix projection of `fecheck.fe.pressure.recovery.project_pressure`, assembled by
    scikit-fem on a P2 line mesh."""
    from skfem import Basis, BilinearForm, ElementLineP2, MeshLine, asm

    @BilinearForm
    def ring_mass(u, v, w):
        return 2 * np.pi * w.x[0] * u * v

    basis = Basis(MeshLine(np.ascontiguousarray(r[::2])), ElementLineP2(), intorder=5)
    order = np.argsort(basis.doflocs[0])
    if not np.allclose(basis.doflocs[0, order], r, atol=1e-9):
        raise FecheckError("ring meniscus: the layer's top nodes are not a quadratic line")
    M = asm(ring_mass, basis).toarray()[np.ix_(order, order)]
    return project_pressure(M, force)


def _axisym_body(name: str, mesh, stiffness, fixed_where, translations=()):
    """(ElasticBody, basis, node positions (2, N)) of an (r, z) P2 vector basis on `mesh`:
    `stiffness(basis)` assembles K; `fixed_where(loc, ir, iz)` lists the fixed dofs."""
    from skfem import Basis, ElementTriP2, ElementVector

    basis = Basis(mesh, ElementVector(ElementTriP2()))
    ir, iz = basis.split_indices()
    loc = basis.doflocs
    fixed = fixed_where(loc, ir, iz)
    free = np.setdiff1d(np.arange(basis.N), fixed)
    position = np.full(basis.N, -1)
    position[free] = np.arange(len(free))
    K = stiffness(basis).tocsr()[free][:, free]
    body = ElasticBody(name, K, position[np.stack([ir, iz], axis=1)],
                np.asarray(translations, dtype=float).reshape(-1, 2))
    return body, loc[:, ir]


def _layer_material(case: RingCase):
    from fecheck.fe.material.elasticity import resolve
    from fecheck.fe.reference.axisym import axisym_stiffness

    form = resolve("auto", case.poisson)
    return lambda basis: axisym_stiffness(basis, case.youngs_MPa, case.poisson, form)


def _meniscus_material(case: RingCase):
    from fecheck.fe.material.anisotropy import axisym_hoop_stiffness

    return lambda basis: axisym_hoop_stiffness(basis, case.meniscus)


def axisym_ring(case: RingCase, size_mm: float = 0.1, *, meniscus_stiffness=None
                ) -> RingAnswer:
    """The axisymmetric solve (module docstring) at element size `size_mm` up to r_o;
    `meniscus_stiffness` (basis → K) replaces the hoop-stiff material (a test's isotropic
    form); with ``case.meniscus`` None the meniscus is left out (sphere on layer)."""
    from skfem import MeshTri

    case.check()
    t0 = time.perf_counter()
    h, R = case.thickness_mm, case.radius_mm
    r = _axis_grid(case, size_mm)
    z = -_growing(0.0, h, size_mm, 1.2, h / 6)[::-1]
    layer, pl = _axisym_body(
        "layer", MeshTri.init_tensor(r, z), _layer_material(case),
        lambda loc, ir, iz: np.concatenate([ir[np.isclose(loc[0, ir], 0.0)],
                                            ir[np.isclose(loc[1, ir], -h)],
                                            iz[np.isclose(loc[1, iz], -h)]]))
    top = np.flatnonzero(np.isclose(pl[1], 0.0))
    top = top[np.argsort(pl[0, top])]
    rt = pl[0, top]
    reach = rt <= case.outer_mm + 1e-9            # without the meniscus: sphere out to r_o
    central = reach & ((rt < case.inner_mm - 1e-9) | (case.meniscus is None))
    under = reach & ~central
    gap = R - np.sqrt(R * R - rt[central] ** 2)
    pairs = [Pair("sphere-layer", "layer", top[central], np.tile([0.0, 1.0], (central.sum(), 1)),
                  gap)]
    bodies = [layer]
    if case.meniscus is not None:
        menisc, pm, levels = _axisym_meniscus(case, r, size_mm, meniscus_stiffness)
        bodies.append(menisc)
        pairs += _axisym_meniscus_pairs(case, pm, levels, top[under], rt[under])
    sol = solve_multibody(bodies, pairs, Indenter(np.array([0.0, -1.0]), case.load_N))
    force = np.zeros(len(top))
    force[central] = sol.pairs["sphere-layer"].force_N
    active = np.zeros(len(top), dtype=bool)
    active[central] = sol.pairs["sphere-layer"].active
    if under.any():
        force[under] = sol.pairs["meniscus-layer"].force_N
        active[under] = sol.pairs["meniscus-layer"].active
    keep = central | under
    rk = rt[keep]
    pressure = _line_pressure(rk, force[keep])
    area = sum(_ring_area(rt[part], pressure[part[keep]], active[part])
               for part in (central, under) if part.any())
    return RingAnswer(float(force[under].sum() / case.load_N), float(pressure.max()),
                      float(area), sol.approach_mm, sol.max_penetration_mm,
                      sum(b.K.shape[0] for b in bodies), time.perf_counter() - t0,
                      f"axisymmetric P2, {size_mm:g} mm")


def _axisym_meniscus(case: RingCase, r: np.ndarray, size_mm: float, stiffness):
    """(ElasticBody, node positions (2, N), levels) of the meniscus: the layer's r nodes in
    [r_i, r_o], uniform `levels` of height mapped onto the wedge; anchored by u_z of the
    outer face's mid-height node, its vertical translation left free."""
    from skfem import MeshTri

    rm = r[(r >= case.inner_mm - 1e-9) & (r <= case.outer_mm + 1e-9)]
    levels = max(4, int(np.ceil(float(case.top(case.outer_mm)) / size_mm)))
    flat = MeshTri.init_tensor(rm, np.linspace(0.0, 1.0, levels + 1))
    p = flat.p.copy()
    p[1] *= case.top(p[0])
    mesh = MeshTri(p, flat.t)
    outer, t_o = case.outer_mm, float(case.top(case.outer_mm))

    def anchor(loc, ir, iz):
        on_rim = np.flatnonzero(np.isclose(loc[0, iz], outer))
        return iz[[on_rim[np.argmin(np.abs(loc[1, iz[on_rim]] - 0.5 * t_o))]]]

    body, loc = _axisym_body("meniscus", mesh, stiffness or _meniscus_material(case), anchor,
                             [[0.0, 1.0]])
    return body, loc, levels


def _axisym_meniscus_pairs(case: RingCase, pm: np.ndarray, levels: int,
                           layer_nodes: np.ndarray, layer_r: np.ndarray) -> list[Pair]:
    """The sphere–superior pair (along the sphere's normal) and the inferior–layer pair
    (node to node on the matching r nodes)."""
    R = case.radius_mm
    bottom = np.flatnonzero(np.isclose(pm[1], 0.0))
    bottom = bottom[np.argsort(pm[0, bottom])]
    if len(bottom) != len(layer_r) or not np.allclose(pm[0, bottom], layer_r, atol=1e-9):
        raise FecheckError("ring meniscus: the meniscus's inferior nodes do not match the "
                           "layer's top nodes")
    eta = pm[1] / case.top(pm[0])
    upper = np.flatnonzero(eta > 1.0 - 0.25 / levels)
    toward = np.array([[0.0], [R]]) - pm[:, upper]
    dist = np.linalg.norm(toward, axis=0)
    return [Pair("sphere-meniscus", "meniscus", upper, (toward / dist).T, dist - R),
            Pair("meniscus-layer", "layer", layer_nodes,
                 np.tile([0.0, 1.0], (len(layer_nodes), 1)), np.zeros(len(layer_nodes)),
                 "meniscus", bottom[:, None], np.ones((len(bottom), 1)))]


def _ring_area(r: np.ndarray, p: np.ndarray, active: np.ndarray) -> float:
    """Area (mm², whole ring) where q = p² of the sorted nodes r (mm), linear between
    nodes, is positive; past the last contact node q is extrapolated from the segment
    before it (the 1-D counterpart of `zero_contour_area`)."""
    q = np.where(active, np.maximum(p, 0.0), 0.0) ** 2
    a, b = r[:-1], r[1:]
    both = active[:-1] & active[1:]
    area = float(np.sum(np.pi * (b[both] ** 2 - a[both] ** 2)))
    for step in (1, -1):                       # contact ends going outward, then inward
        idx = np.arange(len(r))
        end = np.flatnonzero(active & np.roll(~active, -step)
                             & (idx + step >= 0) & (idx + step < len(r)))
        for k in end:
            inside = k - step
            slope = ((q[k] - q[inside]) / (r[k] - r[inside])
                     if 0 <= inside < len(r) and active[inside] else -np.inf)
            q_next = min(q[k] + slope * (r[k + step] - r[k]), -1e-12 * q.max())
            edge = r[k] + (r[k + step] - r[k]) * q[k] / (q[k] - q_next)
            area += abs(np.pi * (edge ** 2 - r[k] ** 2))
    return area


# ----------------------------------------------------------------------------------------
# 3-D quarter model


def _revolve(build, size_field: str, name: str):
    """Linear tetrahedra (points (n, 3), tets (m, 4)) of a section in the x-z plane built
    by `build(gmsh)` (returning its surface tags) and revolved a quarter turn about z,
    sized by the Gmsh MathEval expression `size_field` (mm)."""
    from geometry.gmsh_session import gmsh_session

    with gmsh_session(name) as gmsh:
        occ = gmsh.model.occ
        faces = build(gmsh)
        occ.revolve([(2, f) for f in faces], 0, 0, 0, 0, 0, 1, np.pi / 2)
        occ.removeAllDuplicates()
        occ.synchronize()
        field_tag = gmsh.model.mesh.field.add("MathEval")
        gmsh.model.mesh.field.setString(field_tag, "F", size_field)
        gmsh.model.mesh.field.setAsBackgroundMesh(field_tag)
        for key in ("MeshSizeFromPoints", "MeshSizeFromCurvature", "MeshSizeExtendFromBoundary"):
            gmsh.option.setNumber(f"Mesh.{key}", 0)
        gmsh.model.mesh.generate(3)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, tet_nodes = gmsh.model.mesh.getElementsByType(4)
    tags = tags.astype(np.int64)
    index = np.full(tags.max() + 1, -1, dtype=np.int64)
    index[tags] = np.arange(len(tags))
    tets = index[tet_nodes.astype(np.int64)].reshape(-1, 4)
    used, inverse = np.unique(tets, return_inverse=True)
    return TetMesh(coords.reshape(-1, 3)[used], inverse.reshape(-1, 4))


def _solid_body(name: str, tet: TetMesh, material, fixed_of, tie_faces, translations=()):
    """The ElasticBody of a P2 tetrahedral solid `tet`: `material(tet)` → (mesh, basis, K);
    `fixed_of(points, basis, find_edge)` its fixed dofs; on each (faces (f, 3), normal
    function of points) of `tie_faces` the midside normal displacement is tied to its
    edge's ends (contact at vertices only)."""
    from fecheck.fe.bodies.solid import edge_lookup, tie_matrix

    mesh, basis, K = material(tet)
    x = tet.points
    find_edge = edge_lookup(mesh.edges, mesh.p.shape[1])
    fixed = fixed_of(x, basis, find_edge)
    edges = [TriMesh(x, f).edges_unique for f, _ in tie_faces]
    normals = np.concatenate([nrm(0.5 * (x[e[:, 0]] + x[e[:, 1]]))
                              for e, (_, nrm) in zip(edges, tie_faces, strict=True)])
    edges = np.concatenate(edges)
    mid = basis.edge_dofs[:, find_edge(*edges.T)].T
    ends = basis.nodal_dofs[:, edges.ravel()].T.reshape(-1, 2, 3)
    T, kept = tie_matrix(basis.N, fixed, mid, ends, normals)
    position = np.full(basis.N, -1)
    position[kept] = np.arange(len(kept))
    return ElasticBody(name, (T.T @ K @ T).tocsc(), position[basis.nodal_dofs.T],
                np.asarray(translations, dtype=float).reshape(-1, 3))


def _plane_dofs(basis, find_edge, mesh_edges: np.ndarray, on: np.ndarray,
                components: tuple[int, ...]) -> np.ndarray:
    """The dofs `components` of the vertices `on` (bool (n,)) and of the edges with both
    ends on them."""
    edges = mesh_edges[:, on[mesh_edges[0]] & on[mesh_edges[1]]]
    c = list(components)
    return np.concatenate([basis.nodal_dofs[c][:, on].ravel(),
                           basis.edge_dofs[c][:, find_edge(*edges)].ravel()])


def _boundary_faces(tet: TetMesh) -> np.ndarray:
    """(f, 3) the triangles on the boundary of the tetrahedra."""
    faces = np.sort(tet.tets[:, [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]]].reshape(-1, 3),
                    axis=1)
    unique, count = np.unique(faces, axis=0, return_counts=True)
    return unique[count == 1]


def solid_ring(case: RingCase, size_mm: float = 0.6) -> RingAnswer:
    """The 3-D quarter-model solve (module docstring) with elements of `size_mm` in the
    meniscus and on the layer out to r_o + 1 mm (growing beyond); Gmsh and scikit-fem
    are imported here."""
    from fecheck.fe.pressure.recovery import tributary_areas, zero_contour_area

    case.check()
    t0 = time.perf_counter()
    h, R, ri, ro = case.thickness_mm, case.radius_mm, case.inner_mm, case.outer_mm
    layer_tet = _revolve(lambda g: _layer_section(g, case), f"{size_mm} + 0.3 * max(0, "
                         f"sqrt(x*x + y*y) - {ro + 1.0})", "ring-layer")
    tol = 1e-6 * R
    lx = layer_tet.points
    faces = _boundary_faces(layer_tet)
    top_faces = faces[(np.abs(lx[faces][:, :, 2]) < tol).all(axis=1)]

    def up(p: np.ndarray) -> np.ndarray:
        return np.tile([0.0, 0.0, 1.0], (len(p), 1))

    layer = _solid_body("layer", layer_tet, lambda t: _iso(t, case), lambda x, b, f: (
        _fixed(x, b, f, x[:, 2] < -h + tol)), [(top_faces, up)])
    rt = np.hypot(lx[:, 0], lx[:, 1])
    on_top = np.zeros(len(lx), dtype=bool)
    on_top[top_faces] = True
    reach = on_top & (rt <= ro + tol)             # without the meniscus: sphere out to r_o
    central = reach & ((rt < ri - tol) | (case.meniscus is None))
    under = reach & ~central
    nodes = np.flatnonzero(central)
    pairs = [Pair("sphere-layer", "layer", nodes, up(nodes),
                  R - np.sqrt(R * R - rt[nodes] ** 2))]
    bodies = [layer]
    if case.meniscus is not None:
        menisc, more = _solid_meniscus(case, size_mm, np.flatnonzero(under), lx)
        bodies.append(menisc)
        pairs += more
    sol = solve_multibody(bodies, pairs, Indenter(np.array([0.0, 0.0, -1.0]),
                                                  0.25 * case.load_N))
    force = np.zeros(len(lx))
    active = np.zeros(len(lx), dtype=bool)
    for pair in pairs:
        if pair.slave == "layer":
            force[pair.nodes] = sol.pairs[pair.name].force_N
            active[pair.nodes] = sol.pairs[pair.name].active
    trib = tributary_areas(lx, top_faces)
    pressure = np.divide(force, trib, out=np.zeros_like(force), where=trib > 0)
    area = sum(4.0 * zero_contour_area(lx, top_faces[part[top_faces].all(axis=1)], pressure,
                                       active) for part in (central, under) if part.any())
    return RingAnswer(float(4.0 * force[under].sum() / case.load_N), float(pressure.max()),
                      float(area), sol.approach_mm, sol.max_penetration_mm,
                      sum(b.K.shape[0] for b in bodies), time.perf_counter() - t0,
                      f"3-D quarter, P2 tetrahedra, {size_mm:g} mm")


def _iso(tet, case: RingCase):
    from fecheck.fe.bodies.solid import p2_elasticity
    from fecheck.fe.material.elasticity import resolve

    return p2_elasticity(tet, case.youngs_MPa, case.poisson,
                         formulation=resolve("auto", case.poisson))


def _fixed(x: np.ndarray, basis, find_edge, clamped: np.ndarray) -> np.ndarray:
    """The symmetry planes' normal dofs (x = 0: u_x, y = 0: u_y) and every dof of the
    `clamped` vertices (and edges between them)."""
    edges = np.asarray(basis.mesh.edges)
    tol = 1e-9 * max(1.0, float(np.abs(x).max()))
    return np.unique(np.concatenate([
        _plane_dofs(basis, find_edge, edges, np.abs(x[:, 0]) < tol, (0,)),
        _plane_dofs(basis, find_edge, edges, np.abs(x[:, 1]) < tol, (1,)),
        _plane_dofs(basis, find_edge, edges, clamped, (0, 1, 2))]))


def _layer_section(gmsh, case: RingCase) -> list[int]:
    """The layer's section in the x-z plane, split at r_i and r_o."""
    occ = gmsh.model.occ
    xs = [0.0, case.inner_mm, case.outer_mm, case.layer_radius_mm]
    rects = [occ.addRectangle(a, -case.thickness_mm, 0.0, b - a, case.thickness_mm)
             for a, b in zip(xs[:-1], xs[1:], strict=True)]
    occ.rotate([(2, t) for t in rects], 0, 0, 0, 1, 0, 0, np.pi / 2)
    out, _ = occ.fragment([(2, rects[0])], [(2, t) for t in rects[1:]])
    occ.synchronize()
    return [t for d, t in out if d == 2]


def _meniscus_section(gmsh, case: RingCase) -> list[int]:
    """The meniscus's section in the x-z plane: flat bottom, vertical rim faces and the
    superior arc (centre (0, 0, R − c), radius R)."""
    occ = gmsh.model.occ
    ri, ro = case.inner_mm, case.outer_mm
    pts = [occ.addPoint(ri, 0, 0), occ.addPoint(ro, 0, 0),
           occ.addPoint(ro, 0, float(case.top(ro))), occ.addPoint(ri, 0, float(case.top(ri)))]
    centre = occ.addPoint(0, 0, case.radius_mm - case.clearance_mm)
    lines = [occ.addLine(pts[0], pts[1]), occ.addLine(pts[1], pts[2]),
             occ.addCircleArc(pts[2], centre, pts[3]), occ.addLine(pts[3], pts[0])]
    surface = occ.addPlaneSurface([occ.addCurveLoop(lines)])
    occ.remove([(0, centre)])
    return [surface]


def _solid_meniscus(case: RingCase, size_mm: float, layer_nodes: np.ndarray,
                    layer_points: np.ndarray) -> tuple[ElasticBody, list[Pair]]:
    """The meniscus quarter (hoop fibres, per quadrature point) and its two pairs."""
    from fecheck.fe.material.anisotropy import hoop_directions, p2_transiso

    R, c = case.radius_mm, case.clearance_mm
    tet = _revolve(lambda g: _meniscus_section(g, case), f"{size_mm}", "ring-meniscus")
    x = tet.points
    tol = 1e-6 * R
    faces = _boundary_faces(tet)
    centre = np.array([0.0, 0.0, R - c])
    inferior = faces[(np.abs(x[faces][:, :, 2]) < tol).all(axis=1)]
    superior = faces[(np.abs(np.linalg.norm(x[faces] - centre, axis=2) - R) < tol).all(axis=1)]

    def material(t):
        from skfem import MeshTet

        axis = (np.zeros(3), np.array([0.0, 0.0, 1.0]))
        basis, K = p2_transiso(MeshTet(np.ascontiguousarray(t.points.T),
                                       np.ascontiguousarray(t.tets.T)), case.meniscus,
                               lambda p: hoop_directions(p, *axis))
        return basis.mesh, basis, K

    r = np.hypot(x[:, 0], x[:, 1])
    rim = np.flatnonzero((np.abs(r - case.outer_mm) < tol) & (x[:, 0] > tol) & (x[:, 1] > tol))
    anchor = rim[np.argmin(np.abs(x[rim, 2] - 0.5 * float(case.top(case.outer_mm))))]

    def fixed(p, basis, find_edge):
        return np.concatenate([_fixed(p, basis, find_edge, np.zeros(len(p), bool)),
                               [basis.nodal_dofs[2, anchor]]])

    def sphere_normal(p):
        d = centre - p
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    body = _solid_body("meniscus", tet, material, fixed,
                       [(inferior, lambda p: np.tile([0.0, 0.0, 1.0], (len(p), 1))),
                        (superior, sphere_normal)], [[0.0, 0.0, 1.0]])
    upper = np.unique(superior)
    toward = np.array([0.0, 0.0, R]) - x[upper]
    dist = np.linalg.norm(toward, axis=1)
    up = np.tile([0.0, 0.0, 1.0], (len(layer_nodes), 1))
    face, weights, gap = ray_pairs(layer_points[layer_nodes] - up, up, x, inferior,
                                   size_mm ** 2 / case.inner_mm)
    if np.any(face < 0):
        k = layer_nodes[np.flatnonzero(face < 0)[0]]
        raise FecheckError(f"ring meniscus: the layer's top vertex at "
                           f"{np.round(layer_points[k], 3).tolist()} mm finds no meniscus face "
                           "above it")
    return body, [Pair("sphere-meniscus", "meniscus", upper, toward / dist[:, None], dist - R),
                  Pair("meniscus-layer", "layer", layer_nodes, up, gap - 1.0, "meniscus",
                       inferior[face], weights)]
