"""The small problems of the verification suite (`fecheck.studies.verify`), each a
function of one discretization parameter returning (value, exact value or None).

Units: mm, N, MPa. scikit-fem and Gmsh are imported inside the functions.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from fecheck.fe.bodies.pose import FramePose
from fecheck.reference.closed_forms import (
    column_stiffness,
    ef_sphere_on_plane,
    hertz_sphere_on_plane,
)

Sample = tuple[float, float | None]
"""(value, exact value); exact None: judged against its own refinement (Richardson)."""

E_MPA, R_MM = 20.0, 25.5
DIRECTION = np.array([1.0, 0.5, -0.3])
"""The manufactured displacement u = DIRECTION · sin(πx) sin(πy) sin(πz) on the unit cube."""


# ---------------------------------------------------------------- 3-D P2 elasticity
def _cube(n: int, jitter: float = 0.0):
    """(skfem MeshTet, geometry TetMesh) of the unit cube, n cells a side; interior
    vertices moved by up to `jitter` cells (a fixed seed)."""
    from skfem import MeshTet

    from geometry.mesh import TetMesh

    m = MeshTet.init_tensor(*(np.linspace(0.0, 1.0, n + 1),) * 3)
    p = m.p.copy()
    if jitter:
        inner = np.all((p > 1e-12) & (p < 1 - 1e-12), axis=0)
        rng = np.random.default_rng(7)
        p[:, inner] += jitter / n * rng.uniform(-1, 1, (3, int(inner.sum())))
    return TetMesh(p.T, m.t.T)


def _lame(nu: float) -> tuple[float, float]:
    return E_MPA * nu / ((1 + nu) * (1 - 2 * nu)), E_MPA / (2 * (1 + nu))


def _exact(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(u (3, ...), grad u (3, 3, ...), Hessian of the scalar φ (3, 3, ...)) at x (3, ...)."""
    s, c = np.sin(np.pi * x), np.cos(np.pi * x)
    phi = s[0] * s[1] * s[2]
    dphi = np.pi * np.stack([c[0] * s[1] * s[2], s[0] * c[1] * s[2], s[0] * s[1] * c[2]])
    hess = np.empty((3, 3) + phi.shape)
    for i in range(3):
        for j in range(3):
            if i == j:
                hess[i, j] = -np.pi ** 2 * phi
            else:
                k = 3 - i - j
                hess[i, j] = np.pi ** 2 * c[i] * c[j] * s[k]
    d = DIRECTION.reshape(3, *([1] * phi.ndim))
    return d * phi, np.einsum("i,j...->ij...", DIRECTION, dphi), hess


@lru_cache(maxsize=8)
def manufactured_3d(n: int, nu: float) -> tuple[float, float]:
    """(relative L2 error, relative H1-seminorm error) of fecheck's P2 assembly
    (`fecheck.fe.bodies.solid.p2_elasticity`) on the unit cube, n cells a side, for the body
    force of the manufactured u (zero on the boundary):
    f = −μ Δu − (λ+μ) ∇(∇·u), Δu = −3π² u, ∇(∇·u) = H(φ)·DIRECTION."""
    import scipy.sparse.linalg as sla
    from skfem import Basis, ElementTetP2, ElementVector, Functional, LinearForm, asm

    from fecheck.fe.bodies.solid import p2_elasticity

    lam, mu = _lame(nu)
    mesh, basis, K = p2_elasticity(_cube(n), E_MPA, nu)
    fine = Basis(mesh, ElementVector(ElementTetP2()), intorder=4)

    @LinearForm
    def load(v, w):
        u, _, hess = _exact(w.x)
        f = 3 * np.pi ** 2 * mu * u - (lam + mu) * np.einsum("ij...,j->i...", hess, DIRECTION)
        return sum(f[i] * v[i] for i in range(3))

    b = asm(load, fine)
    inner = np.setdiff1d(np.arange(basis.N), basis.get_dofs().flatten())
    uh = np.zeros(basis.N)
    uh[inner] = sla.spsolve(K.tocsr()[inner][:, inner].tocsc(), b[inner])
    field = fine.interpolate(uh)

    @Functional
    def l2(w):
        u, _, _ = _exact(w.x)
        return sum((w["uh"][i] - u[i]) ** 2 for i in range(3))

    @Functional
    def h1(w):
        _, g, _ = _exact(w.x)
        return sum((w["uh"].grad[i][j] - g[i, j]) ** 2 for i in range(3) for j in range(3))

    l2_u = math.sqrt(float(np.sum(DIRECTION ** 2)) / 8)               # ∫φ² = 1/8
    h1_u = math.sqrt(float(np.sum(DIRECTION ** 2)) * 3 * np.pi ** 2 / 8)  # ∫|∇φ|² = 3π²/8
    return (math.sqrt(l2.assemble(fine, uh=field)) / l2_u,
            math.sqrt(h1.assemble(fine, uh=field)) / h1_u)


def patch_p2(n: int, nu: float) -> float:
    """Largest error (mm) of fecheck's P2 solve reproducing the linear displacement
    u = A x + b (no body force, u given on the boundary) on a distorted cube mesh."""
    import scipy.sparse.linalg as sla
    from skfem import Basis, ElementTetP2, ElementVector

    from fecheck.fe.bodies.solid import p2_elasticity

    mesh, basis, K = p2_elasticity(_cube(n, jitter=0.3), E_MPA, nu)
    return _patch_error(Basis(mesh, ElementVector(ElementTetP2())), K.tocsr(), sla)


def patch_p1(n: int, nu: float) -> float:
    """The same patch test with linear tetrahedra (scikit-fem's own elasticity form)."""
    import scipy.sparse.linalg as sla
    from skfem import Basis, ElementTetP1, ElementVector, MeshTet, asm
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    tets = _cube(n, jitter=0.3)
    mesh = MeshTet(tets.points.T, tets.tets.T)
    basis = Basis(mesh, ElementVector(ElementTetP1()))
    K = asm(linear_elasticity(*lame_parameters(E_MPA, nu)), basis).tocsr()
    return _patch_error(basis, K, sla)


def _patch_error(basis, K, sla) -> float:
    """Largest |u_h − u| (mm) with u = A x + b imposed on the boundary dofs of `basis`."""
    A = np.array([[0.01, -0.02, 0.005], [0.015, 0.002, -0.01], [-0.004, 0.012, 0.02]])
    linear = A @ basis.doflocs + np.array([[0.1], [-0.2], [0.05]])
    exact = np.empty(basis.N)
    for k, idx in enumerate(basis.split_indices()):
        exact[idx] = linear[k, idx]
    bnd = basis.get_dofs().flatten()
    inner = np.setdiff1d(np.arange(basis.N), bnd)
    u = exact.copy()
    u[inner] = sla.spsolve(K[inner][:, inner].tocsc(), -(K[inner][:, bnd] @ exact[bnd]))
    return float(np.abs(u - exact).max())


# ---------------------------------------------------------------- load scaling
def load_scaling(nu: float, factor: float = 3.7) -> float:
    """‖u(factor·f) − factor·u(f)‖ / ‖u(factor·f)‖ of fecheck's bonded layer
    (`fecheck.fe.bodies.solid.layer_solid`, 4 mm on a 20 mm square, no contact) under a
    non-uniform normal pressure: linear small strain makes it round-off."""
    import scipy.sparse.linalg as sla

    from fecheck.fe.bodies.solid import layer_solid
    from geometry.mesh import TriMesh

    xs = np.linspace(-10.0, 10.0, 11)
    gx, gy = np.meshgrid(xs, xs, indexing="ij")
    points = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)])
    i, j = np.meshgrid(np.arange(10), np.arange(10), indexing="ij")
    v0 = (i * 11 + j).ravel()
    faces = np.concatenate([np.column_stack([v0, v0 + 11, v0 + 12]),
                            np.column_stack([v0, v0 + 12, v0 + 1])])
    solid = layer_solid(TriMesh(points, faces), 4.0, E_MPA, nu, layers=2)
    pressure = 1.0 + 0.1 * points[:, 0] + 0.02 * points[:, 1] ** 2        # MPa
    f = solid.normal_rows.T @ (-pressure * solid.tributary_mm2)
    u1 = sla.spsolve(solid.K, f)
    u2 = sla.spsolve(solid.K, factor * f)
    return float(np.linalg.norm(u2 - factor * u1) / np.linalg.norm(u2))


# ---------------------------------------------------------------- EF on meshes
def _ef_icosphere(level: int, depth_mm: float, rotation: np.ndarray | None = None):
    """The EF law's result for a level-`level` icosphere (R 25.5) `depth_mm` into the
    plane z = 0, both turned by `rotation` (None: not turned)."""
    from fecheck import laws
    from fecheck.contact.analytic import Plane
    from fecheck.contact.pair import ContactPair
    from geometry.icosphere import icosphere

    rot = np.eye(3) if rotation is None else rotation
    pair = ContactPair(icosphere(R_MM, level), Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]))
    centre = np.array([0.0, 0.0, R_MM - depth_mm])
    surface = pair.evaluate((rot, rot @ centre), (rot, np.zeros(3)))
    return laws.elastic_foundation(surface, column_stiffness(E_MPA, 0.3, 6.0))


def ef_icosphere(level: int, quantity: str, depth_mm: float = 0.955) -> Sample:
    """EF force or area of the icosphere against the cap closed form:
    F = k·πd²(R − d/3), A = π(2Rd − d²)."""
    r = _ef_icosphere(level, depth_mm)
    k = column_stiffness(E_MPA, 0.3, 6.0)
    d = depth_mm
    if quantity == "force":
        return float(np.linalg.norm(r.force)), k * math.pi * d * d * (R_MM - d / 3)
    return float(r.area), math.pi * (2 * R_MM * d - d * d)


def ef_invariance(tilt_deg: float, spin_deg: float) -> float:
    """Largest relative change of |F|, area and p_max of the level-4 icosphere EF
    contact when sphere and plane are tilted by `tilt_deg` about x and turned by
    `spin_deg` about z together (a rigid motion of the whole problem)."""
    from fecheck.statics.frames import rotation

    rot = rotation(0.0, 0.0, math.radians(spin_deg)) @ rotation(math.radians(tilt_deg), 0.0,
                                                                  0.0)
    flat, turned = _ef_icosphere(4, 0.955), _ef_icosphere(4, 0.955, rot)
    pairs = [(np.linalg.norm(flat.force), np.linalg.norm(turned.force)),
             (flat.area, turned.area), (flat.max_pressure, turned.max_pressure)]
    return float(max(abs(b / a - 1) for a, b in pairs))


def ef_plate(size_mm: float, depth_mm: float = 0.955) -> Sample:
    """EF force of a flat Gmsh plate (element `size_mm`) pressed by an analytic sphere
    against the cap closed form."""
    from fecheck import laws
    from fecheck.contact.analytic import Sphere
    from fecheck.contact.pair import ContactPair
    from geometry.plateau import plane_patch

    plate = plane_patch((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), radius=9.0, size=size_mm)
    pair = ContactPair(plate, Sphere([0.0, 0.0, R_MM - depth_mm], R_MM))
    eye, zero = np.eye(3), np.zeros(3)
    k = column_stiffness(E_MPA, 0.3, 6.0)
    r = laws.elastic_foundation(pair.evaluate((eye, zero), (eye, zero)), k)
    d = depth_mm
    return float(np.linalg.norm(r.force)), k * math.pi * d * d * (R_MM - d / 3)


def hertz_two_bodies(depth_mm: float = 0.3) -> float:
    """Relative error of the Hertz law (`fecheck.laws.hertz` with `laws.hertz_modulus`
    of a 20 MPa / 0.45 layer against a 460 MPa / 0.45 body) against
    P = 4/3·E*·√R·d^(3/2), 1/E* = Σ(1 − ν_i²)/E_i, written out here; the icosphere is
    turned so that a vertex is the deepest point (the law reads the deepest vertex)."""
    from fecheck import laws
    from fecheck.contact.analytic import Plane
    from fecheck.contact.pair import ContactPair
    from geometry.icosphere import icosphere

    mesh = icosphere(R_MM, 3)
    v = mesh.points[0] / np.linalg.norm(mesh.points[0])
    rot = _rotation_onto(v, np.array([0.0, 0.0, -1.0]))
    e_star = 1.0 / ((1 - 0.45 ** 2) / 20.0 + (1 - 0.45 ** 2) / 460.0)
    pair = ContactPair(mesh, Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]))
    surface = pair.evaluate((rot, np.array([0.0, 0.0, R_MM - depth_mm])),
                            (np.eye(3), np.zeros(3)))
    r = laws.hertz(surface, R_MM, laws.hertz_modulus(20.0, 0.45, 460.0, 0.45))
    exact = 4.0 / 3.0 * e_star * math.sqrt(R_MM) * depth_mm ** 1.5
    return float(abs(np.linalg.norm(r.force) / exact - 1))


def _rotation_onto(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The rotation taking unit vector a onto unit vector b (Rodrigues; a ≠ −b)."""
    v, c = np.cross(a, b), float(a @ b)
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx / (1 + c)


# ---------------------------------------------------------------- axisymmetric contact
def axisym_hertz(size_mm: float, quantity: str) -> Sample:
    """Axisymmetric FE of a 60 mm block (80 mm disc, 20 N, R 25.5, E 20, ν 0.3) against
    Hertz: p_max or the contact radius."""
    res = _hertz_block(size_mm)
    hz = hertz_sphere_on_plane(20.0, R_MM, E_MPA, 0.3)
    if quantity == "p_max":
        return res.metrics.max_pressure_MPa, hz.max_pressure_MPa
    return math.sqrt(res.metrics.area_mm2 / math.pi), math.sqrt(hz.area_mm2 / math.pi)


@lru_cache(maxsize=4)
def _hertz_block(size_mm: float):
    from fecheck.fe.reference.axisym import axisym_sphere_on_layer

    return axisym_sphere_on_layer(20.0, R_MM, E_MPA, 0.3, 60.0, layer_radius_mm=80.0,
                                  size_mm=size_mm)


def axisym_layer(size_mm: float, nu: float) -> Sample:
    """p_max of the axisymmetric FE of the baseline medial contact (323.71 N, R 25.5,
    6 mm layer, E 20) at Poisson's ratio `nu`: judged against its own refinement."""
    from fecheck.fe.reference.axisym import axisym_sphere_on_layer

    res = axisym_sphere_on_layer(323.71, R_MM, E_MPA, nu, 6.0, size_mm=size_mm)
    return res.metrics.max_pressure_MPa, None


def thin_layer(h_over_a: float, quantity: str) -> Sample:
    """Axisymmetric FE of a thin compressible bonded layer (ν 0.3, R 100 mm, EF contact
    radius a = 10 mm, thickness h = a·`h_over_a`, element h/8) against the column law
    (the a ≫ h limit: the EF cap), at the EF's load: p_max or the indentation depth."""
    res, ef = _thin_layer(h_over_a)
    if quantity == "p_max":
        return res.metrics.max_pressure_MPa, ef.max_pressure_MPa
    return res.metrics.depth_mm, ef.depth_mm


@lru_cache(maxsize=4)
def _thin_layer(h_over_a: float):
    """(FE result, EF closed form) of `thin_layer`."""
    from fecheck.fe.reference.axisym import axisym_sphere_on_layer

    radius, a, nu = 100.0, 10.0, 0.3
    h = a * h_over_a
    k = column_stiffness(E_MPA, nu, h)
    d = a * a / (2 * radius)
    load = k * math.pi * d * d * (radius - d / 3)
    res = axisym_sphere_on_layer(load, radius, E_MPA, nu, h, layer_radius_mm=60.0,
                                 size_mm=h / 8)
    return res, ef_sphere_on_plane(load, radius, E_MPA, nu, h)


def patch_traction(n: int, nu: float, stress_MPa: float = 0.5) -> float:
    """Largest error (mm) of fecheck's P2 solve on a distorted unit cube under a uniform
    pressure `stress_MPa` on its top, with symmetry planes x = 0, y = 0, z = 0
    (u_x, u_y, u_z zero there) and the other faces free: the exact answer is linear,
    u = (νσx/E, νσy/E, −σz/E). Unlike a Dirichlet patch test it reads the traction
    boundary, where the symmetric-gradient term of the form matters."""
    import scipy.sparse.linalg as sla
    from skfem import Basis, ElementTetP2, ElementVector, FacetBasis, LinearForm, asm

    mesh, basis, K = p2_elasticity_cube(n, nu)
    top = mesh.facets_satisfying(lambda x: np.isclose(x[2], 1.0))
    fbasis = FacetBasis(mesh, ElementVector(ElementTetP2()), facets=top)

    @LinearForm
    def pressure(v, w):
        return -stress_MPa * v[2]

    b = asm(pressure, fbasis)
    comp = basis.split_indices()
    loc = Basis(mesh, ElementVector(ElementTetP2())).doflocs
    fixed = np.concatenate([idx[np.isclose(loc[k, idx], 0.0)] for k, idx in enumerate(comp)])
    free = np.setdiff1d(np.arange(basis.N), fixed)
    u = np.zeros(basis.N)
    K = K.tocsr()
    u[free] = sla.spsolve(K[free][:, free].tocsc(), b[free])
    strain = np.array([nu, nu, -1.0]) * stress_MPa / E_MPA
    exact = np.empty(basis.N)
    for k, idx in enumerate(comp):
        exact[idx] = strain[k] * loc[k, idx]
    return float(np.abs(u - exact).max())


def p2_elasticity_cube(n: int, nu: float):
    """fecheck's P2 assembly (`fecheck.fe.bodies.solid.p2_elasticity`) on the distorted cube."""
    from fecheck.fe.bodies.solid import p2_elasticity

    return p2_elasticity(_cube(n, jitter=0.3), E_MPA, nu)


@lru_cache(maxsize=4)
def _baseline_axisym():
    """The fine axisymmetric reference of the baseline medial contact (0.05 mm)."""
    from fecheck.fe.reference.axisym import axisym_sphere_on_layer

    return axisym_sphere_on_layer(323.71, R_MM, E_MPA, 0.3, 6.0, size_mm=0.05).metrics


@lru_cache(maxsize=4)
def _baseline_3d(size_mm: float):
    from fecheck.fe.reference.sphere_layer import sphere_on_flat_layer

    return sphere_on_flat_layer(323.71, R_MM, E_MPA, 0.3, 6.0, refine_size_mm=size_mm,
                                size_mm=max(2.0, size_mm), layers=3, grading=1.6).metrics


@lru_cache(maxsize=2)
def _ring_axisym():
    """The axisymmetric ring-meniscus reference at 0.1 mm."""
    from fecheck.fe.reference.ring_meniscus import RingCase, axisym_ring

    return axisym_ring(RingCase(), 0.1)


@lru_cache(maxsize=4)
def _ring_3d(size_mm: float):
    from fecheck.fe.reference.ring_meniscus import RingCase, solid_ring

    return solid_ring(RingCase(), size_mm)


def ring_meniscus(size_mm: float, quantity: str) -> Sample:
    """The ring meniscus (`fecheck.fe.reference.ring_meniscus`: 300 N, R 25, ring 6-12 mm, hoop
    fibres) by the 3-D quarter model at element `size_mm` against the axisymmetric FE at
    0.1 mm: `quantity` "share", "p_max_MPa" or "area_mm2" of the layer."""
    return getattr(_ring_3d(size_mm), quantity), getattr(_ring_axisym(), quantity)


def fe3d_layer(size_mm: float, quantity: str) -> Sample:
    """The general 3-D FE contact path (`fecheck.fe.reference.sphere_layer`: extruded P2 layer, 3
    levels through 6 mm, exact frictionless contact) of the baseline medial contact
    (323.71 N, R 25.5, E 20, ν 0.3) against the axisymmetric FE at 0.05 mm: the
    indentation depth or the contact area, element `size_mm` under the contact."""
    fe, ref = _baseline_3d(size_mm), _baseline_axisym()
    if quantity == "depth":
        return fe.depth_mm, ref.depth_mm
    return fe.area_mm2, ref.area_mm2


def _pressed_layer(surface, up: np.ndarray, load_N: float, settings) -> np.ndarray:
    """(p_max MPa, summed contact force N, approach mm, contact vertices) of the general
    FE path: `surface` extruded 6 mm (E 20, ν 0.3), pressed along -`up` by a rigid
    sphere (R 25.5) touching it at the origin."""
    from fecheck.fe.bodies.indenter import SphereIndenter
    from fecheck.fe.bodies.scene_bodies import FEBody
    from fecheck.fe.reference.sphere_layer import candidate_margin
    from fecheck.fe.solve.press import build_layers, push_drive, solve_pressed

    indenter = SphereIndenter(R_MM * up, R_MM)
    body = FEBody("layer", surface, np.full(surface.n_points, 6.0), indenter, "plane",
                  indenter.describe(), "uniform")
    layer = build_layers([body], E_MPA, 0.3, settings, lambda m: None)[0]
    drive = push_drive(FramePose.identity("W", "T"), -load_N * up)
    sol, _, _, _ = solve_pressed([layer], drive, candidate_margin(load_N, R_MM, E_MPA, 0.3),
                                 settings, lambda m: None)
    c = sol.layers[0]
    return np.array([float((c.force_N / layer.solid.tributary_mm2).max()),
                     float(c.force_N.sum()), float(sol.q[0]), float(c.active.sum())])


def fe3d_invariance(tilt_deg: float, spin_deg: float, load_N: float = 100.0) -> float:
    """Largest relative change of p_max, the summed contact force, the approach and the
    number of contact vertices of the 3-D FE path when the whole problem (the layer's
    surface, the sphere, the load) is tilted by `tilt_deg` about x and turned by
    `spin_deg` about z: the same mesh, turned, so only round-off may differ."""
    from fecheck.fe.reference.sphere_layer import flat_layer
    from fecheck.statics.frames import rotation
    from geometry.mesh import TriMesh

    layer, settings = flat_layer(load_N, R_MM, E_MPA, 0.3, 6.0, refine_size_mm=2.0,
                                 size_mm=3.0, layers=2)
    flat = layer.body.surface
    rot = rotation(0.0, 0.0, math.radians(spin_deg)) @ rotation(math.radians(tilt_deg), 0.0,
                                                                  0.0)
    up = np.array([0.0, 0.0, 1.0])
    a = _pressed_layer(flat, up, load_N, settings)
    b = _pressed_layer(TriMesh(flat.points @ rot.T, flat.faces), rot @ up, load_N, settings)
    return float(np.max(np.abs(b / a - 1)))


# ---------------------------------------------------------------- thin bonded layers
THIN_A_MM, THIN_R_MM = 10.0, 100.0
"""Punch radius and sphere contact radius a (mm), sphere radius R (mm) of the thin-layer
cases; the layer's thickness is a·(h/a)."""


def thin_punch(h_over_a: float, nu: float, column: bool) -> Sample:
    """Stiffness P/δ (N/mm) of the axisymmetric FE (`fecheck.fe.reference.axisym.axisym_flat_punch`,
    element h/8, formulation per ν) of a rigid flat punch (a 10 mm) on a bonded layer of
    thickness a·`h_over_a`, against the column law Mπa²/h (`column`: the leading term
    for a compressible layer, βa ≫ 1) or the thin-layer asymptote
    (`fecheck.reference.thin_layer.flat_punch_stiffness`: the leading term when βa is
    of order 1, ν near 1/2)."""
    from fecheck.fe.reference.axisym import axisym_flat_punch
    from fecheck.reference.thin_layer import flat_punch_stiffness

    h = THIN_A_MM * h_over_a
    depth = 0.01 * h
    force = axisym_flat_punch(depth, THIN_A_MM, E_MPA, nu, h, size_mm=h / 8)
    if column:
        return force / depth, column_stiffness(E_MPA, nu, h) * math.pi * THIN_A_MM ** 2
    return force / depth, flat_punch_stiffness(E_MPA, nu, h, THIN_A_MM)


def thin_sphere(h_over_a: float, nu: float, quantity: str) -> Sample:
    """The axisymmetric FE (element h/8, formulation per ν) of a rigid sphere (R 100 mm)
    on a bonded layer of thickness a·`h_over_a`, at the load that gives the thin-layer
    asymptote (`fecheck.reference.thin_layer.sphere_at_radius`) a contact radius a of
    10 mm: p_max ("p_max"), the approach ("depth") or the contact radius ("radius")
    against the asymptote's."""
    res, ref = _thin_sphere(h_over_a, nu)
    m = res.metrics
    if quantity == "p_max":
        return m.max_pressure_MPa, ref.max_pressure_MPa
    if quantity == "depth":
        return m.depth_mm, ref.depth_mm
    return math.sqrt(m.area_mm2 / math.pi), ref.radius_mm


@lru_cache(maxsize=8)
def _thin_sphere(h_over_a: float, nu: float):
    """(FE result, thin-layer answer) of `thin_sphere`."""
    from fecheck.fe.reference.axisym import axisym_sphere_on_layer
    from fecheck.reference.thin_layer import sphere_at_radius

    h = THIN_A_MM * h_over_a
    ref = sphere_at_radius(THIN_A_MM, THIN_R_MM, E_MPA, nu, h)
    res = axisym_sphere_on_layer(ref.load_N, THIN_R_MM, E_MPA, nu, h, layer_radius_mm=60.0,
                                 size_mm=h / 8, reach_mm=1.3 * THIN_A_MM)
    return res, ref
