"""Compiled (numba) contact kernels: candidate faces → the arrays of a `ContactSurface`.

One evaluation of a contact pair is a few hundred faces of arithmetic; in NumPy it costs
~90 small array operations of 1-5 µs each, so these loops are compiled instead
(``@njit(cache=True)``: compiled once, then loaded from ``__pycache__``).

* `surface_quadrature` — the shared core: vertex depths, world positions and depth twists
  of the contact faces → quadrature points (clipped at zero depth, or whole faces at the
  deepest vertex's depth, see `fecheck.contact.surface`), their weights and twists.
* `plane_surface`, `sphere_surface` — the analytic masters of the statics' hot path:
  depths of the candidate faces in closed form, the contact faces, their normals and
  the vertex data, then `surface_quadrature`. Other masters (polynomial, meshes, the
  thesis's detectors) form the vertex data in NumPy (`fecheck.contact.surface.build_surface`)
  and call `surface_quadrature` directly.
* `mesh_surface`, `walked_mesh_surface` — mesh masters from their vertex depths; the
  second also finds the closest faces from the last call's (a warm-started walk, only
  for the points that can be in contact), so that an evaluation that reuses its
  candidate set is one compiled call.
* `sphere_ray_depth` (one point) and `sphere_depths` (arrays) — the sphere master's ray
  depth and gradients, also behind `fecheck.contact.analytic.Sphere.depth_values`;
  `sphere_ray_roots` — the nearer line-sphere intersection (the FE's rigid sphere,
  `fecheck.fe.bodies.indenter.SphereIndenter`); one line-sphere formula behind both.

Conventions (mm, world frame): a vertex twist row is ``(∂d/∂v, ∂d/∂ω)``; poses are
``y = R p + t`` (slave → master frame) and ``x = Rm y + tm`` (master → world).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fecheck.contact.clip import N_POINTS, RULE, clip_line_motion, face_rule, pattern_of
from fecheck.contact.coherent import closest_on_triangle, coherent_closest

NO_RIM = np.zeros((0, 3))
"""The rim table of a pair without a rim fade (`fade_at_rim`; a width of 0)."""


# One fused compiled loop over the faces for speed: its branches are the cases of one
# evaluation, kept together on purpose (hence above the complexity ceiling).
@njit(cache=True, fastmath=False)
def surface_quadrature(clipped: bool, moving: bool, D: np.ndarray, X: np.ndarray,  # noqa: C901
                       T: np.ndarray, area: np.ndarray, cos_abs: np.ndarray,
                       weight_rate: np.ndarray):
    """Quadrature of m contact faces.

    Parameters
    ----------
    clipped : True: the positive part of each face; False: whole faces at the depth (and
        depth twist) of their deepest vertex
    moving : with `clipped`, the points move with the clip line: the twists are total
        derivatives and the `clip_*` arrays give the slide. Without it the points keep
        their barycentric coordinates (enough for the linear law, whose resultant's
        clip-line terms cancel: the rule is exact for its integrands, which vanish on
        the clip line) and the `clip_*` arrays are empty.
    D : (m, 3) vertex depths, mm;  X : (m, 3, 3) world vertices, mm
    T : (m, 3, 6) vertex depth twists ∂d/∂ξ, (1, mm)
    area : (m,) face areas, mm²
    cos_abs : (m,) weight per unit area (|cos| of the projection; 1: plain areas)
    weight_rate : (m, 6) ∂cos_abs/∂ξ (zero for plain areas)

    Returns
    -------
    qp_face (Q,), qp_bary (Q, 3), qp_point (Q, 3), qp_depth (Q,), qp_weight (Q,),
    qp_depth_twist (Q, 6), qp_weight_twist (Q, 6): total derivatives, with the motion of
    the points on clipped faces; and that motion (`fecheck.contact.clip.clip_line_motion`):
    qp_clip (Q,) the cut face of each point (−1: none; empty in whole-face mode),
    clip_share (Q, 2), clip_face (C,) contact face of each cut face, clip_edge (C, 2, 3),
    clip_rate (C, 2, 6)
    """
    m = D.shape[0]
    n_q = n_cut = 0
    for f in range(m):
        if clipped:
            pattern = pattern_of(D[f, 0], D[f, 1], D[f, 2])
            n_q += N_POINTS[pattern]
            if moving and pattern != 7:
                n_cut += 1
        else:
            n_q += 3
    face = np.empty(n_q, dtype=np.int64)
    bary = np.empty((n_q, 3))
    frac = np.empty(n_q)
    point = np.empty((n_q, 3))
    depth = np.empty(n_q)
    weight = np.empty(n_q)
    depth_twist = np.empty((n_q, 6))
    weight_twist = np.empty((n_q, 6))
    qp_clip = np.full(n_q if n_cut else 0, -1, dtype=np.int64)
    clip_share = np.empty((n_q if n_cut else 0, 2))
    clip_face = np.empty(n_cut, dtype=np.int64)
    clip_edge = np.empty((n_cut, 2, 3))
    clip_rate = np.empty((n_cut, 2, 6))
    corner = np.empty((6, 3))
    slot = np.empty(3, dtype=np.int64)
    rate = np.empty(6)
    cof = np.empty((3, 3))
    row = cut = 0
    for f in range(m):
        if clipped:
            end = face_rule(D[f, 0], D[f, 1], D[f, 2], bary, frac, row, corner)
        else:
            end = row + 3
            for q in range(3):
                for k in range(3):
                    bary[row + q, k] = RULE[q, k]
                frac[row + q] = 1.0 / 3.0
        deepest = 0
        for j in range(1, 3):
            if D[f, j] > D[f, deepest]:
                deepest = j
        moves = n_cut > 0 and pattern_of(D[f, 0], D[f, 1], D[f, 2]) != 7
        for q in range(row, end):
            b0, b1, b2 = bary[q, 0], bary[q, 1], bary[q, 2]
            face[q] = f
            for k in range(3):
                point[q, k] = b0 * X[f, 0, k] + b1 * X[f, 1, k] + b2 * X[f, 2, k]
            if clipped:
                depth[q] = b0 * D[f, 0] + b1 * D[f, 1] + b2 * D[f, 2]
                if not moves:                   # else clip_line_motion writes it
                    for k in range(6):
                        depth_twist[q, k] = (b0 * T[f, 0, k] + b1 * T[f, 1, k]
                                             + b2 * T[f, 2, k])
            else:
                depth[q] = D[f, deepest]
                for k in range(6):
                    depth_twist[q, k] = T[f, deepest, k]
            a = frac[q] * area[f]
            weight[q] = a * cos_abs[f]
            for k in range(6):
                weight_twist[q, k] = a * weight_rate[f, k]
        if moves:
            clip_face[cut] = f
            clip_line_motion(f, cut, row, D, X, T, area[f] * cos_abs[f], corner, slot, rate,
                             cof, depth_twist, weight_twist, qp_clip, clip_share, clip_edge,
                             clip_rate)
            cut += 1
        row = end
    return (face, bary, point, depth, weight, depth_twist, weight_twist, qp_clip, clip_share,
            clip_face, clip_edge, clip_rate)


@njit(cache=True, fastmath=False, inline="always")
def mat_vec(A: np.ndarray, v0: float, v1: float, v2: float) -> tuple[float, float, float]:
    """A v for a (3, 3) matrix A."""
    return (A[0, 0] * v0 + A[0, 1] * v1 + A[0, 2] * v2,
            A[1, 0] * v0 + A[1, 1] * v1 + A[1, 2] * v2,
            A[2, 0] * v0 + A[2, 1] * v1 + A[2, 2] * v2)


@njit(cache=True, fastmath=False, inline="always")
def _vertex(T: np.ndarray, X: np.ndarray, i: int, j: int, x: tuple, g: tuple,
            arm: tuple) -> None:
    """Store world vertex x in X[i, j] and its depth twist (g, arm × g) in T[i, j]."""
    X[i, j, 0], X[i, j, 1], X[i, j, 2] = x
    T[i, j, 0], T[i, j, 1], T[i, j, 2] = g
    T[i, j, 3] = arm[1] * g[2] - arm[2] * g[1]
    T[i, j, 4] = arm[2] * g[0] - arm[0] * g[2]
    T[i, j, 5] = arm[0] * g[1] - arm[1] * g[0]


@njit(cache=True, fastmath=False)
def _slave_to_master(points: np.ndarray, R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """y = R p + t for the candidate points (n, 3)."""
    y = np.empty_like(points)
    for i in range(points.shape[0]):
        y0, y1, y2 = mat_vec(R, points[i, 0], points[i, 1], points[i, 2])
        y[i, 0], y[i, 1], y[i, 2] = y0 + t[0], y1 + t[1], y2 + t[2]
    return y


@njit(cache=True, fastmath=False)
def _contact_faces(D: np.ndarray) -> np.ndarray:
    """Indices of the faces with a positive vertex depth."""
    keep = np.empty(D.shape[0], dtype=np.int64)
    m = 0
    for f in range(D.shape[0]):
        if D[f, 0] > 0.0 or D[f, 1] > 0.0 or D[f, 2] > 0.0:
            keep[m] = f
            m += 1
    return keep[:m]


@njit(cache=True, fastmath=False, inline="always")
def _ray_sphere(y0: float, y1: float, y2: float, u0: float, u1: float, u2: float,
                center: np.ndarray, radius: float):
    """The line y + s·u (unit u) and the sphere |x − c| = R: r = y − c (3 floats),
    b = u·r, |r|² and the discriminant b² − |r|² + R² (the line meets the sphere iff
    ≥ 0, at s = −b ± √disc)."""
    r0, r1, r2 = y0 - center[0], y1 - center[1], y2 - center[2]
    b = u0 * r0 + u1 * r1 + u2 * r2
    rr = r0 * r0 + r1 * r1 + r2 * r2
    return r0, r1, r2, b, rr, b * b - rr + radius * radius


@njit(cache=True, fastmath=False)
def sphere_ray_roots(y: np.ndarray, u: np.ndarray, center: np.ndarray, radius: float):
    """The nearer intersection of the lines y + s·u (points y (n, 3), unit directions u
    (n, 3)) with the sphere: s (n,) mm, and hit (n,) False where the line misses (s 0)."""
    n = y.shape[0]
    s = np.zeros(n)
    hit = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        _, _, _, b, _, disc = _ray_sphere(y[i, 0], y[i, 1], y[i, 2], u[i, 0], u[i, 1],
                                          u[i, 2], center, radius)
        if disc >= 0.0:
            s[i] = -b - np.sqrt(disc)
            hit[i] = True
    return s, hit


@njit(cache=True, fastmath=False, inline="always")
def sphere_ray_depth(y0: float, y1: float, y2: float, u0: float, u1: float, u2: float,
                     center: np.ndarray, radius: float):
    """Depth (mm) of point y along unit u to the sphere: the larger root ``s`` with
    ``y + s·u`` on it, or ``R - |y - c|`` where the line misses the ball. Returns
    (depth, ∂d/∂y as 3 floats, ray) with ray False where the radial gradient is used
    (missed line, or a ray tangent to the sphere)."""
    r0, r1, r2, b, rr, disc = _ray_sphere(y0, y1, y2, u0, u1, u2, center, radius)
    if disc >= 0.0:
        d = np.sqrt(disc) - b
        q0, q1, q2 = r0 + d * u0, r1 + d * u1, r2 + d * u2        # sphere point - c
        qu = q0 * u0 + q1 * u1 + q2 * u2
        if abs(qu) > 1e-12 * radius:
            k = -1.0 / qu
            return d, k * q0, k * q1, k * q2, True
    else:
        d = radius - np.sqrt(rr)
    k = -1.0 / np.sqrt(max(rr, 1e-300))
    return d, k * r0, k * r1, k * r2, False


@njit(cache=True, fastmath=False)
def sphere_depths(y: np.ndarray, u: np.ndarray, center: np.ndarray, radius: float):
    """`sphere_ray_depth` over points y (n, 3) and unit directions u (n, 3): depth (n,),
    ∂d/∂y (n, 3), ∂d/∂u (n, 3) (d·∂d/∂y on a ray, zero with the radial gradient)."""
    n = y.shape[0]
    depth = np.empty(n)
    g = np.empty((n, 3))
    h = np.zeros((n, 3))
    for i in range(n):
        d, g0, g1, g2, ray = sphere_ray_depth(y[i, 0], y[i, 1], y[i, 2],
                                              u[i, 0], u[i, 1], u[i, 2], center, radius)
        depth[i], g[i, 0], g[i, 1], g[i, 2] = d, g0, g1, g2
        if ray:
            h[i, 0], h[i, 1], h[i, 2] = d * g0, d * g1, d * g2
    return depth, g, h


@njit(cache=True, fastmath=False)
def plane_surface(clipped: bool, moving: bool, points: np.ndarray, local_faces: np.ndarray,
                  normals: np.ndarray, areas: np.ndarray, R: np.ndarray, t: np.ndarray,
                  Rm: np.ndarray, tm: np.ndarray, Rs: np.ndarray, plane_point: np.ndarray,
                  plane_normal: np.ndarray):
    """Contact of candidate slave faces with the half-space below a plane.

    points (n, 3), local_faces (mc, 3), normals (mc, 3) outward, areas (mc,): the
    candidates in the slave frame (mm, mm²). Depth along the plane normal n (master
    frame), foundation normal n (fixed in the master), weights projected on the plane:
    area·|cos|, cos = (Rs n_face)·(Rm n).

    clipped, moving: as for `surface_quadrature`. Returns (hit (m,) indices into the
    candidates, normal (m, 3), vertex_depth (m, 3)) followed by the arrays of
    `surface_quadrature`.
    """
    n0, n1, n2 = plane_normal[0], plane_normal[1], plane_normal[2]
    offset = plane_point[0] * n0 + plane_point[1] * n1 + plane_point[2] * n2
    y = _slave_to_master(points, R, t)
    dv = np.empty(points.shape[0])
    for i in range(points.shape[0]):
        dv[i] = offset - (y[i, 0] * n0 + y[i, 1] * n1 + y[i, 2] * n2)
    Dc = np.empty((local_faces.shape[0], 3))
    for f in range(local_faces.shape[0]):
        for j in range(3):
            Dc[f, j] = dv[local_faces[f, j]]
    hit = _contact_faces(Dc)
    m = hit.size
    nw = mat_vec(Rm, n0, n1, n2)
    g = (-nw[0], -nw[1], -nw[2])
    D = np.empty((m, 3))
    X = np.empty((m, 3, 3))
    T = np.empty((m, 3, 6))
    N = np.empty((m, 3))
    area = np.empty(m)
    cos_abs = np.empty(m)
    rate = np.zeros((m, 6))
    for i in range(m):
        f = hit[i]
        for j in range(3):
            v = local_faces[f, j]
            D[i, j] = Dc[f, j]
            x0, x1, x2 = mat_vec(Rm, y[v, 0], y[v, 1], y[v, 2])
            x = (x0 + tm[0], x1 + tm[1], x2 + tm[2])
            _vertex(T, X, i, j, x, g, x)
        N[i, 0], N[i, 1], N[i, 2] = nw
        area[i] = areas[f]
        a0, a1, a2 = mat_vec(Rs, normals[f, 0], normals[f, 1], normals[f, 2])
        cos = a0 * nw[0] + a1 * nw[1] + a2 * nw[2]
        sign = 1.0 if cos > 0.0 else (-1.0 if cos < 0.0 else 0.0)
        cos_abs[i] = abs(cos)
        rate[i, 3] = sign * (a1 * nw[2] - a2 * nw[1])          # ∂cos/∂ω = n_face × n
        rate[i, 4] = sign * (a2 * nw[0] - a0 * nw[2])
        rate[i, 5] = sign * (a0 * nw[1] - a1 * nw[0])
    return (hit, N, D) + surface_quadrature(clipped, moving, D, X, T, area, cos_abs, rate)


@njit(cache=True, fastmath=False)
def sphere_surface(clipped: bool, moving: bool, points: np.ndarray, local_faces: np.ndarray,
                   normals: np.ndarray, areas: np.ndarray, R: np.ndarray, t: np.ndarray,
                   Rm: np.ndarray, tm: np.ndarray, Rs: np.ndarray, center: np.ndarray,
                   radius: float):
    """Contact of candidate slave faces with a solid ball (`fecheck.contact.analytic.Sphere`).

    Depth of a vertex along the face's foundation normal u = -R n_face (master frame)
    to the sphere (`sphere_ray_depth`); foundation normal -Rs n_face (fixed in the
    slave), plain slave areas. The depth twist of a vertex is (g, (x + d u) × g) with
    g = ∂d/∂y (world), which accounts for the turn of u with the slave. Arguments and
    returns as `plane_surface`.
    """
    n_c = local_faces.shape[0]
    y = _slave_to_master(points, R, t)
    r2 = radius * radius
    rr = np.empty(points.shape[0])              # |y - c|², mm²
    for v in range(points.shape[0]):
        rr[v] = ((y[v, 0] - center[0]) ** 2 + (y[v, 1] - center[1]) ** 2
                 + (y[v, 2] - center[2]) ** 2)
    # A vertex has a positive depth iff it is inside the ball, or the line along u meets
    # the ball ahead of it (b = u·(y - c) < 0 and a real root): faces with such a vertex
    # are kept, and their depths computed exactly below.
    near = np.empty(n_c, dtype=np.int64)
    m = 0
    for f in range(n_c):
        u0, u1, u2 = mat_vec(R, -normals[f, 0], -normals[f, 1], -normals[f, 2])
        for j in range(3):
            v = local_faces[f, j]
            b = (u0 * (y[v, 0] - center[0]) + u1 * (y[v, 1] - center[1])
                 + u2 * (y[v, 2] - center[2]))
            if rr[v] < r2 or (b < 0.0 and b * b - rr[v] + r2 >= 0.0):
                near[m] = f
                m += 1
                break
    Dc = np.empty((m, 3))
    G = np.empty((m, 3, 3))                   # ∂d/∂y, master frame
    for i in range(m):
        f = near[i]
        u0, u1, u2 = mat_vec(R, -normals[f, 0], -normals[f, 1], -normals[f, 2])
        for j in range(3):
            v = local_faces[f, j]
            d, g0, g1, g2, _ = sphere_ray_depth(y[v, 0], y[v, 1], y[v, 2], u0, u1, u2,
                                                center, radius)
            Dc[i, j], G[i, j, 0], G[i, j, 1], G[i, j, 2] = d, g0, g1, g2
    keep = _contact_faces(Dc)
    m = keep.size
    hit = near[keep]
    D = np.empty((m, 3))
    X = np.empty((m, 3, 3))
    T = np.empty((m, 3, 6))
    N = np.empty((m, 3))
    area = np.empty(m)
    for i in range(m):
        f = hit[i]
        k = keep[i]
        nw = mat_vec(Rs, -normals[f, 0], -normals[f, 1], -normals[f, 2])   # = Rm u
        for j in range(3):
            v = local_faces[f, j]
            d = Dc[k, j]
            D[i, j] = d
            x0, x1, x2 = mat_vec(Rm, y[v, 0], y[v, 1], y[v, 2])
            x = (x0 + tm[0], x1 + tm[1], x2 + tm[2])
            g = mat_vec(Rm, G[k, j, 0], G[k, j, 1], G[k, j, 2])
            _vertex(T, X, i, j, x, g, (x[0] + d * nw[0], x[1] + d * nw[1], x[2] + d * nw[2]))
        N[i, 0], N[i, 1], N[i, 2] = nw
        area[i] = areas[f]
    return (hit, N, D) + surface_quadrature(clipped, moving, D, X, T, area, np.ones(m),
                                            np.zeros((m, 6)))



@njit(cache=True, fastmath=False)
def _signed(o0: float, o1: float, o2: float, sq: float, out: bool, n0: float, n1: float,
            n2: float) -> tuple[float, float, float, float]:
    """Depth (mm, positive inside) and its gradient of a point at offset o from its
    closest point (squared distance sq) on a face with unit normal n."""
    dist = np.sqrt(sq)
    if dist < 1e-12:
        return (-dist if out else dist), -n0, -n1, -n2
    s = -1.0 / dist if out else 1.0 / dist
    return (-dist if out else dist), s * o0, s * o1, s * o2


@njit(cache=True, fastmath=False, inline="always")
def rim_weight(phi: float, rim_mm: float) -> tuple[float, float]:
    """The rim fade w = 3x² - 2x³, x = min(1, max(0, φ/rim_mm)), of a master point at
    distance φ (mm) from the rim, and dw/dφ (1/mm): 0 on the rim, 1 from `rim_mm` in."""
    x = phi / rim_mm
    if x >= 1.0:
        return 1.0, 0.0
    if x <= 0.0:
        return 0.0, 0.0
    return x * x * (3.0 - 2.0 * x), 6.0 * x * (1.0 - x) / rim_mm


@njit(cache=True, fastmath=False)
def rim_weights(phi: np.ndarray, rim_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """`rim_weight` over distances phi (n,) mm: w (n,) and dw/dφ (n,) 1/mm."""
    w, dw = np.empty(phi.shape[0]), np.empty(phi.shape[0])
    for i in range(phi.shape[0]):
        w[i], dw[i] = rim_weight(phi[i], rim_mm)
    return w, dw


@njit(cache=True, fastmath=False, inline="always")
def _rim_faded(d: float, g0: float, g1: float, g2: float, qx: float, qy: float, qz: float,
               f: int, E: np.ndarray, rim: np.ndarray, rim_mm: float
               ) -> tuple[float, float, float, float]:
    """Depth d and gradient g of a point whose closest master point q lies on face f,
    faded near the master's rim: w·d with w the `rim_weight` of φ(q), φ the
    distance to the rim interpolated over the face from its corners (rim (n_faces, 3),
    mm; E the master's `edge_frames`). The gradient adds d·w'(φ)·∇φ, ∇φ the in-plane
    gradient of φ over the face (exact while q is inside the face; at a rim edge or
    vertex φ = 0, so w = w' = 0: no contact behind the rim)."""
    abx, aby, abz = E[f, 3], E[f, 4], E[f, 5]
    acx, acy, acz = E[f, 6], E[f, 7], E[f, 8]
    wx, wy, wz = qx - E[f, 0], qy - E[f, 1], qz - E[f, 2]
    g11 = abx * abx + aby * aby + abz * abz
    g12 = abx * acx + aby * acy + abz * acz
    g22 = acx * acx + acy * acy + acz * acz
    det = g11 * g22 - g12 * g12
    r1 = abx * wx + aby * wy + abz * wz
    r2 = acx * wx + acy * wy + acz * wz
    s = (g22 * r1 - g12 * r2) / det
    t = (g11 * r2 - g12 * r1) / det
    p1, p2 = rim[f, 1] - rim[f, 0], rim[f, 2] - rim[f, 0]
    w, dw = rim_weight(rim[f, 0] + s * p1 + t * p2, rim_mm)
    if w == 1.0:
        return d, g0, g1, g2
    if w == 0.0:
        return 0.0, 0.0, 0.0, 0.0
    k = d * dw
    alpha = k * (g22 * p1 - g12 * p2) / det
    beta = k * (g11 * p2 - g12 * p1) / det
    return (w * d, w * g0 + alpha * abx + beta * acx, w * g1 + alpha * aby + beta * acy,
            w * g2 + alpha * abz + beta * acz)


@njit(cache=True, fastmath=False)
def fade_at_rim(points: np.ndarray, face: np.ndarray, depth: np.ndarray, grad: np.ndarray,
                E: np.ndarray, rim: np.ndarray, rim_mm: float) -> None:
    """`_rim_faded` in place over points (n, 3) with closest master faces face (n,),
    depths (n,) and gradients (n, 3) (master frame, mm)."""
    for i in range(points.shape[0]):
        f = face[i]
        qx, qy, qz, _ = closest_on_triangle(points[i, 0], points[i, 1], points[i, 2], E, f)
        depth[i], grad[i, 0], grad[i, 1], grad[i, 2] = _rim_faded(
            depth[i], grad[i, 0], grad[i, 1], grad[i, 2], qx, qy, qz, f, E, rim, rim_mm)


@njit(cache=True, fastmath=False)
def signed_closest(points: np.ndarray, closest: np.ndarray, sq: np.ndarray,
                   face_normal: np.ndarray, outside: np.ndarray, by_normal: bool):
    """Signed depth (n,) (mm, positive inside) and its gradient (n, 3) from closest
    points (n, 3) and squared distances (n,) on a mesh master (master frame).

    Outside is the side of the closest face's normal face_normal (n, 3) if `by_normal`,
    else `outside` (n,) bool. The gradient is minus the outward unit direction from the
    closest point (minus the face normal for a point on the surface).
    """
    n = points.shape[0]
    depth = np.empty(n)
    grad = np.empty((n, 3))
    for i in range(n):
        o0 = points[i, 0] - closest[i, 0]
        o1 = points[i, 1] - closest[i, 1]
        o2 = points[i, 2] - closest[i, 2]
        n0, n1, n2 = face_normal[i, 0], face_normal[i, 1], face_normal[i, 2]
        out = (o0 * n0 + o1 * n1 + o2 * n2 > 0.0) if by_normal else outside[i]
        depth[i], grad[i, 0], grad[i, 1], grad[i, 2] = _signed(o0, o1, o2, sq[i], out,
                                                                n0, n1, n2)
    return depth, grad


@njit(cache=True, fastmath=False)
def mesh_surface(clipped: bool, moving: bool, local_faces: np.ndarray, y: np.ndarray,
                 dv: np.ndarray, grad: np.ndarray, normals: np.ndarray, areas: np.ndarray,
                 Rm: np.ndarray, tm: np.ndarray, Rs: np.ndarray):
    """Contact of candidate slave faces with a mesh master from its vertex depths.

    y (n, 3) candidate points in the master frame (mm), dv (n,) their signed depths
    (mm), grad (n, 3) ∂d/∂y (master frame); local_faces, normals, areas as in
    `plane_surface`. Foundation normal -Rs n_face (fixed in the slave), plain slave
    areas; a vertex's depth twist is (g, x × g), g = Rm ∂d/∂y. Returns as
    `plane_surface`.
    """
    Dc = np.empty((local_faces.shape[0], 3))
    for f in range(local_faces.shape[0]):
        for j in range(3):
            Dc[f, j] = dv[local_faces[f, j]]
    hit = _contact_faces(Dc)
    m = hit.size
    D = np.empty((m, 3))
    X = np.empty((m, 3, 3))
    T = np.empty((m, 3, 6))
    N = np.empty((m, 3))
    area = np.empty(m)
    for i in range(m):
        f = hit[i]
        for j in range(3):
            v = local_faces[f, j]
            D[i, j] = Dc[f, j]
            x0, x1, x2 = mat_vec(Rm, y[v, 0], y[v, 1], y[v, 2])
            x = (x0 + tm[0], x1 + tm[1], x2 + tm[2])
            _vertex(T, X, i, j, x, mat_vec(Rm, grad[v, 0], grad[v, 1], grad[v, 2]), x)
        N[i, 0], N[i, 1], N[i, 2] = mat_vec(Rs, -normals[f, 0], -normals[f, 1], -normals[f, 2])
        area[i] = areas[f]
    return (hit, N, D) + surface_quadrature(clipped, moving, D, X, T, area, np.ones(m),
                                            np.zeros((m, 6)))


@njit(cache=True, fastmath=False)
def walked_mesh_surface(clipped: bool, moving: bool, points: np.ndarray, local_faces: np.ndarray,
                        normals: np.ndarray, areas: np.ndarray, R: np.ndarray, t: np.ndarray,
                        Rm: np.ndarray, tm: np.ndarray, Rs: np.ndarray, E: np.ndarray,
                        ring_ptr: np.ndarray, ring_index: np.ndarray, master_normals: np.ndarray,
                        rim: np.ndarray, rim_mm: float, face: np.ndarray, position: np.ndarray,
                        upper: np.ndarray, travel: np.ndarray, ring: np.ndarray,
                        max_steps: int):
    """`mesh_surface` of a mesh master (inside by the closest face's normal), from the
    last call's state of the candidate points, in one compiled call.

    face, position, upper, travel, ring: the points' `fecheck.contact.coherent.WalkState`,
    updated in place. A point moved by δ since the last call has a depth at most
    upper + δ (the signed distance is 1-Lipschitz); a face whose vertices all have a
    negative bound is not in contact and its vertices need no closest point. The others
    are found by `fecheck.contact.coherent.coherent_closest` (E, ring_ptr, ring_index:
    the master's `edge_frames` and `face_rings`; master_normals (n_faces, 3) its unit
    face normals). With rim_mm > 0 the depths fade to zero at the master's rim
    (`_rim_faded`, rim (n_faces, 3) its corners' distances to the rim, mm); `upper` keeps
    the unfaded depth (the fade keeps its sign or makes it 0).

    Returns (settled,) followed by the returns of `mesh_surface`; if a walk does not
    settle, settled is False, the contact is empty and the state is spoilt (the caller
    queries the tree).
    """
    y = _slave_to_master(points, R, t)
    n = y.shape[0]
    moved = np.empty(n)
    dv = np.empty(n)                    # the depth, or its (negative) bound if not needed
    for p in range(n):
        moved[p] = np.sqrt((y[p, 0] - position[p, 0]) ** 2 + (y[p, 1] - position[p, 1]) ** 2
                           + (y[p, 2] - position[p, 2]) ** 2)
        dv[p] = upper[p] + moved[p]
    need = np.zeros(n, dtype=np.bool_)
    for f in range(local_faces.shape[0]):
        a, b, c = local_faces[f, 0], local_faces[f, 1], local_faces[f, 2]
        if dv[a] >= 0.0 or dv[b] >= 0.0 or dv[c] >= 0.0:
            need[a] = need[b] = need[c] = True
    grad = np.zeros((n, 3))
    for p in range(n):
        position[p, 0], position[p, 1], position[p, 2] = y[p, 0], y[p, 1], y[p, 2]
        travel[p] += moved[p]
        if not need[p]:
            upper[p] = dv[p]
            continue
        px, py, pz = y[p, 0], y[p, 1], y[p, 2]
        f, qx, qy, qz, sq, ok = coherent_closest(px, py, pz, face[p], ring[p], travel[p], E,
                                                 ring_ptr, ring_index, max_steps)
        if not ok:
            return (False,) + mesh_surface(clipped, moving, local_faces[:0], y, dv, grad,
                                           normals[:0], areas[:0], Rm, tm, Rs)
        o0, o1, o2 = px - qx, py - qy, pz - qz
        n0, n1, n2 = master_normals[f, 0], master_normals[f, 1], master_normals[f, 2]
        dv[p], grad[p, 0], grad[p, 1], grad[p, 2] = _signed(
            o0, o1, o2, sq, o0 * n0 + o1 * n1 + o2 * n2 > 0.0, n0, n1, n2)
        face[p], upper[p] = f, dv[p]
        if rim_mm > 0.0:
            dv[p], grad[p, 0], grad[p, 1], grad[p, 2] = _rim_faded(
                dv[p], grad[p, 0], grad[p, 1], grad[p, 2], qx, qy, qz, f, E, rim, rim_mm)
    return (True,) + mesh_surface(clipped, moving, local_faces, y, dv, grad, normals, areas,
                                  Rm, tm, Rs)
