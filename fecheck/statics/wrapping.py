"""Ligament paths over wrap objects: the shortest path from a point P to a point Q that
does not pass through a cylinder or an ellipsoid fixed to one body, as OpenSim's
``PathWrap`` replaces the straight line (quadrant 'all': either side, the shorter way).

Everything is in the frame of the body the object is fixed to (mm). P is the *free* end
(on the other body), Q the end on the object's body.

* **Cylinder** (exact): in the plane across the axis the path is the tangent from p to the
  circle, an arc of it and the tangent to q, of length H = s₁ + r·φ + s₂; unrolled, the
  surface and the two tangent segments are a plane, so the path is straight there and
  L = √(H² + Δz²) with Δz the axial rise from P to Q, shared between the three parts in
  proportion to their lengths.
* **Ellipsoid** (the shortest planar path): a plane through P and Q cuts the ellipsoid
  in an ellipse, around which the shortest path within the plane is exact (the affine
  map x = c + R·D·y of the ellipsoid onto the unit sphere takes the section to a circle
  and keeps lines straight and tangent lines tangent: the circle's two tangents and
  arc, mapped back; the arc's length in mm by Gauss-Legendre quadrature). The
  plane is turned about PQ from the one through the centre to the shortest such path
  (Newton steps on the turn angle ψ with central differences, `PLANE_ITERATIONS`). The
  ellipsoid's geodesic is not planar in general; measured against OpenSim 4.6's
  'hybrid' method on the lenhart2015 MCL at rest, the planar path is 0.0003-0.0007 mm
  longer (the plane through the centre alone, the sphere's mapped path, up to 1.03 mm).
* **No wrap** when the straight segment misses the object (it meets it iff the tangents'
  angles α₁ + α₂ are less than the angle between p and q seen from the axis or centre,
  φ > 0), or when an end is inside it (OpenSim's rule): the straight line.

Statics. The path length L depends on P only through the pose of the free body relative
to the object's body, so a spring along it of tension f(L) stores V(L) with dV = f·dL:
the free body gets the force F = −f·∇_P L at P (by the envelope theorem of a shortest
path ∇_P L is the unit vector from the first tangent point T₁ to P: F acts along the
straight segment P-T₁), and the object's body, V being unchanged by a common rigid
motion of both bodies, gets −F on the same line of action, so −F at T₁ (or, the same
wrench, at P). The ellipsoid's planar path is not a geodesic and its ∇_P L is not
exactly along P-T₁ (measured within 1e-3 rad); the force keeps F = −f·∇_P L,
energy-consistent.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

GAUSS_POINTS = 8
"""Gauss-Legendre points on the ellipsoid's arc: they give the 64-point value of the MCL
arcs at rest to 1e-13 mm."""
STEP_MM = 0.01
"""Central-difference step (mm) of the ellipsoid path's partial derivatives in P:
rounding ~1e-16·L/h² ≈ 1e-10 /mm, truncation ~h²/s³ ≈ 1e-8 /mm for segments s ≥ 20 mm."""
PLANE_ITERATIONS = 12
"""At most this many Newton steps on the ellipsoid path's plane (each at most 0.2 rad,
0.2 rad downhill where the length is not convex in the turn; they stop when all are below
1e-8 rad): the MCL paths at rest converge in 5."""
PLANE_STEP = 1e-3
"""The turn (rad) of the central differences of those steps."""
_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(GAUSS_POINTS)


BODIES = {"femur_distal_r": "femur", "tibia_proximal_r": "tibia", "patella_r": "patella"}
"""The source model's bodies → the bone names of the bundle data."""


@dataclass(frozen=True, eq=False)
class WrapObject:
    """A wrap object fixed to the bone `body` ('femur', 'tibia', 'patella'), in the data's
    frame at rest (mm): a cylinder (axis the local z, radius radii[0]) or an ellipsoid
    (radii along the local x, y, z); `axes` (3, 3) has the local axes as columns."""

    body: str
    cylinder: bool
    centre: np.ndarray
    axes: np.ndarray
    radii: np.ndarray

    @classmethod
    def of(cls, geometry: dict) -> WrapObject:
        """The object of a ``wrap.geometry`` entry of the data (`WrapEllipsoid` or
        `WrapCylinder` with ``osim_body``, ``centre_mm``, ``local_axes_in_this_frame``,
        ``radii_mm`` or ``radius_mm``)."""
        cyl = geometry["type"] == "WrapCylinder"
        axes = np.column_stack([geometry["local_axes_in_this_frame"][k] for k in "xyz"])
        u, _, vt = np.linalg.svd(axes.astype(float))       # the data's 6 decimals, made
        radii = [geometry["radius_mm"]] * 3 if cyl else geometry["radii_mm"]
        return cls(BODIES[geometry["osim_body"]], cyl,           # orthonormal (1e-6)
                   np.asarray(geometry["centre_mm"], dtype=float), u @ vt,
                   np.asarray(radii, dtype=float))


@dataclass(frozen=True, eq=False)
class WrapObjects:
    """n wrap objects (`WrapObject`), one per path, stacked: cylinder (n,) bool, centre
    (n, 3) mm, axes (n, 3, 3), radii (n, 3) mm."""

    cylinder: np.ndarray
    centre: np.ndarray
    axes: np.ndarray
    radii: np.ndarray

    @classmethod
    def of(cls, objects: Sequence[WrapObject]) -> WrapObjects:
        """The stack of `objects` (at least one)."""
        return cls(np.array([o.cylinder for o in objects]),
                   np.array([o.centre for o in objects]), np.array([o.axes for o in objects]),
                   np.array([o.radii for o in objects]))

    def tiled(self, k: int) -> WrapObjects:
        """The n objects repeated k times (k·n)."""
        return WrapObjects(*(np.tile(a, (k,) + (1,) * (a.ndim - 1))
                             for a in (self.cylinder, self.centre, self.axes, self.radii)))

    def take(self, index: np.ndarray) -> WrapObjects:
        """The objects at `index`."""
        return WrapObjects(self.cylinder[index], self.centre[index], self.axes[index],
                           self.radii[index])


@dataclass(frozen=True, eq=False)
class Paths:
    """Shortest paths from P to Q (n each): length (n,) mm, whether each wraps (n,) and
    its tangent points (n, 3) each (P and Q where it does not wrap), the object's frame;
    `turn` (n,) rad: an ellipsoid path's plane (`length_derivatives` starts there)."""

    length_mm: np.ndarray
    wraps: np.ndarray
    first: np.ndarray
    second: np.ndarray
    turn: np.ndarray | None = None


def _norm(a: np.ndarray) -> np.ndarray:
    """Row norms of an (n, 3) array."""
    return np.sqrt(np.einsum("ij,ij->i", a, a))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a × b of (n, 3) arrays (np.cross costs several times more)."""
    return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                     a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)


def _circle(rp: np.ndarray, rq: np.ndarray, angle: np.ndarray, r: np.ndarray):
    """In a plane: from a point at distance rp from a circle's centre (radius r) to one
    at rq, `angle` apart: (wraps, α₁, α₂, arc angle φ, tangent lengths s₁, s₂), α the
    angle between each point and its tangent point seen from the centre."""
    outside = (rp > r) & (rq > r)
    a1 = np.arccos(np.clip(r / np.where(outside, rp, 2 * r), -1, 1))
    a2 = np.arccos(np.clip(r / np.where(outside, rq, 2 * r), -1, 1))
    phi = angle - a1 - a2
    wraps = outside & (phi > 0)
    s1 = np.sqrt(np.maximum(rp * rp - r * r, 0.0))
    s2 = np.sqrt(np.maximum(rq * rq - r * r, 0.0))
    return wraps, a1, a2, np.where(wraps, phi, 0.0), s1, s2


def _plane(a: np.ndarray, b: np.ndarray, normal: np.ndarray | None = None):
    """Orthonormal e₁ along a and e₂ toward b (n, k), the angle between a and b, |a|, |b|
    (a perpendicular e₂ of `normal` × e₁, or any, when b is along a)."""
    ra, rb = _norm(a), _norm(b)
    e1 = a / ra[:, None]
    across = b - np.sum(b * e1, axis=1)[:, None] * e1
    n = _norm(across)
    if normal is None:
        other = np.where(np.abs(e1[:, :1]) < 0.9, np.eye(3)[0], np.eye(3)[1])
        fallback = _cross(np.broadcast_to(other, e1.shape), e1)
    else:
        fallback = _cross(normal, e1)
    fallback /= _norm(fallback)[:, None]
    e2 = np.where((n > 1e-12 * rb)[:, None], across / np.maximum(n, 1e-300)[:, None],
                  fallback)
    angle = np.arctan2(n, np.sum(b * e1, axis=1))
    return e1, e2, angle, ra, rb


def _cylinder(obj: WrapObjects, p: np.ndarray, q: np.ndarray, hessian: bool):
    """Cylinder paths (`Paths`) and, with `hessian`, ∇_P L (n, 3) and ∇²_P L (n, 3, 3)."""
    r = obj.radii[:, 0]
    lp = np.einsum("nji,nj->ni", obj.axes, p - obj.centre)       # local coordinates
    lq = np.einsum("nji,nj->ni", obj.axes, q - obj.centre)
    p2 = np.concatenate([lp[:, :2], np.zeros((len(r), 1))], axis=1)
    q2 = np.concatenate([lq[:, :2], np.zeros((len(r), 1))], axis=1)
    e1, e2, angle, rp, rq = _plane(p2, q2, np.tile([0.0, 0.0, 1.0], (len(r), 1)))
    wraps, a1, a2, phi, s1, s2 = _circle(rp, rq, angle, r)
    h = s1 + r * phi + s2
    dz = lq[:, 2] - lp[:, 2]
    t1 = r[:, None] * (np.cos(a1)[:, None] * e1 + np.sin(a1)[:, None] * e2)
    t2 = r[:, None] * (np.cos(angle - a2)[:, None] * e1 + np.sin(angle - a2)[:, None] * e2)
    hs = np.where(wraps, h, 1.0)
    t1[:, 2] = lp[:, 2] + dz * s1 / hs
    t2[:, 2] = lp[:, 2] + dz * (s1 + r * phi) / hs
    straight = _norm(p - q)
    length = np.where(wraps, np.sqrt(h * h + dz * dz), straight)
    first = np.where(wraps[:, None], _body(obj, t1), q)
    second = np.where(wraps[:, None], _body(obj, t2), p)
    paths = Paths(length, wraps, first, second)
    if not hessian:
        return paths, None, None
    grad, hess = _straight_derivatives(p, q)
    if wraps.any():
        w = wraps
        e = (p2[w] - np.concatenate([t1[w, :2], np.zeros((w.sum(), 1))], axis=1)) / s1[w, None]
        lw = length[w]
        v = h[w, None] * e
        v[:, 2] = -dz[w]
        g = v / lw[:, None]                                       # ∇L in local axes
        ee = e[:, :, None] * e[:, None, :]
        flat = np.diag([1.0, 1.0, 0.0])
        jv = ee + (h[w] / s1[w])[:, None, None] * (flat - ee)
        jv[:, 2, 2] = 1.0
        hl = (jv - g[:, :, None] * g[:, None, :]) / lw[:, None, None]
        ax = obj.axes[w]
        grad[w] = np.einsum("nij,nj->ni", ax, g)
        hess[w] = ax @ hl @ np.transpose(ax, (0, 2, 1))
    return paths, grad, hess


def _cylinder_paths(obj: WrapObjects, p: np.ndarray, q: np.ndarray) -> Paths:
    return _cylinder(obj, p, q, False)[0]


def _body(obj: WrapObjects, local: np.ndarray) -> np.ndarray:
    """Points (n, 3) in the objects' local axes → their body's frame, mm."""
    return obj.centre + np.einsum("nij,nj->ni", obj.axes, local)


def _straight_derivatives(p: np.ndarray, q: np.ndarray):
    d = p - q
    length = _norm(d)
    u = d / length[:, None]
    return u, (np.eye(3) - u[:, :, None] * u[:, None, :]) / length[:, None, None]


def _unit_ball(obj: WrapObjects, p: np.ndarray, q: np.ndarray):
    """P and Q in the coordinates y that map the ellipsoids onto the unit sphere (n, 3),
    and whether the segment PQ meets the ellipsoid with both ends outside (n,)."""
    yp = np.einsum("nji,nj->ni", obj.axes, p - obj.centre) / obj.radii
    yq = np.einsum("nji,nj->ni", obj.axes, q - obj.centre) / obj.radii
    d = yq - yp
    s = np.clip(-np.sum(yp * d, axis=1) / np.maximum(np.sum(d * d, axis=1), 1e-300), 0, 1)
    near = yp + s[:, None] * d
    meets = ((np.sum(near * near, axis=1) < 1.0) & (np.sum(yp * yp, axis=1) > 1.0)
             & (np.sum(yq * yq, axis=1) > 1.0))
    return yp, yq, meets


def _ellipsoid_plane(obj: WrapObjects, p: np.ndarray, q: np.ndarray, yp: np.ndarray,
                     yq: np.ndarray, psi: np.ndarray, points: bool = False):
    """Path lengths (n,) over ellipsoids that the segments PQ meet, in the plane through P
    and Q turned by ψ (n,) rad about PQ from the plane through the centre (yp, yq: P and
    Q in unit-sphere coordinates): the section is an ellipse, and the planar path is
    exact for it (the affine map of the circle's two tangents and arc). With `points`,
    also its tangent points (n, 3) each."""
    scale = obj.radii
    w = yq - yp
    w /= _norm(w)[:, None]
    m0 = _cross(yp, yq)
    size = _norm(m0)
    other = np.where(np.abs(w[:, :1]) < 0.9, np.eye(3)[0], np.eye(3)[1])
    m0 = np.where((size > 1e-12)[:, None], m0, _cross(w, other))
    m0 /= _norm(m0)[:, None]
    m = np.cos(psi)[:, None] * m0 + np.sin(psi)[:, None] * _cross(w, m0)
    d = np.sum(m * yp, axis=1)
    o = d[:, None] * m                                  # the section circle's centre
    rho = np.sqrt(np.maximum(1.0 - d * d, 0.0))
    e1, e2, angle, rp, rq = _plane(yp - o, yq - o, m)
    _, a1, a2, phi, _, _ = _circle(rp, rq, angle, rho)
    b1, b2 = a1, angle - a2
    t1 = _body(obj, scale * (o + rho[:, None] * (np.cos(b1)[:, None] * e1
                                                 + np.sin(b1)[:, None] * e2)))
    t2 = _body(obj, scale * (o + rho[:, None] * (np.cos(b2)[:, None] * e1
                                                 + np.sin(b2)[:, None] * e2)))
    beta = 0.5 * (b1 + b2)[:, None] + 0.5 * phi[:, None] * _NODES      # (n, k)
    tangent = (-np.sin(beta)[:, :, None] * e1[:, None, :]
               + np.cos(beta)[:, :, None] * e2[:, None, :]) * scale[:, None, :]
    arc = 0.5 * phi * rho * (np.sqrt(np.sum(tangent * tangent, axis=2)) @ _WEIGHTS)
    length = _norm(p - t1) + arc + _norm(q - t2)
    return (length, t1, t2) if points else length


def _ellipsoid(obj: WrapObjects, p: np.ndarray, q: np.ndarray,
               start: np.ndarray | None = None) -> tuple[Paths, np.ndarray]:
    """Ellipsoid paths (`Paths`): the shortest planar path (module docstring) where the
    segment meets the ellipsoid, else the segment; and the planes' turns ψ (n,) rad,
    searched from `start` (None: 0)."""
    yp, yq, wraps = _unit_ball(obj, p, q)
    length = _norm(p - q)
    first, second, turn = q.copy(), p.copy(), np.zeros(len(p))
    if wraps.any():
        o, pw, qw, ypw, yqw = obj.take(wraps), p[wraps], q[wraps], yp[wraps], yq[wraps]
        three = o.tiled(3)
        args = [np.tile(a, (3, 1)) for a in (pw, qw, ypw, yqw)]
        shift = np.repeat([-PLANE_STEP, 0.0, PLANE_STEP], len(pw))
        psi = np.zeros(len(pw)) if start is None else start[wraps]
        for _ in range(PLANE_ITERATIONS):
            lo, mid, hi = _ellipsoid_plane(three, *args, np.tile(psi, 3) + shift).reshape(3, -1)
            curv = lo - 2 * mid + hi
            step = np.where(curv > 0, -0.5 * PLANE_STEP * (hi - lo)
                            / np.maximum(curv, 1e-300), -0.2 * np.sign(hi - lo))
            psi = psi + np.clip(step, -0.2, 0.2)
            if np.abs(step).max() < 1e-8:
                break
        length[wraps], first[wraps], second[wraps] = _ellipsoid_plane(
            o, pw, qw, ypw, yqw, psi, points=True)
        turn[wraps] = psi
    return Paths(length, wraps, first, second), turn


_OFFSETS = np.concatenate([np.zeros((1, 3)), np.eye(3), -np.eye(3),
                           *[np.array([s * np.eye(3)[i] + t * np.eye(3)[j]
                                       for s, t in ((1, 1), (1, -1), (-1, 1), (-1, -1))])
                             for i in range(3) for j in range(i + 1, 3)]])
"""The 19 points of the central differences (`_ellipsoid_derivatives`), in steps."""


def _ellipsoid_derivatives(obj: WrapObjects, p: np.ndarray, q: np.ndarray,
                           start: np.ndarray | None = None):
    """L (n,), ∇_P L (n, 3) and ∇²_P L (n, 3, 3) of the ellipsoid paths. With ℓ(P, ψ) the
    planar path's length in the plane turned by ψ and ψ* its minimum: ∇L = ∂ℓ/∂P (the
    envelope theorem) and ∇²L = ℓ_PP − ℓ_Pψ·ℓ_Pψᵀ / ℓ_ψψ (ψ*'s own change with P), the
    partial derivatives by central differences (steps `STEP_MM`, `PLANE_STEP`) at ψ*,
    all 33 points in one vectorised evaluation."""
    n, h, d = len(p), STEP_MM, PLANE_STEP
    psi = _ellipsoid(obj, p, q, start)[1]
    shifts = np.concatenate([_OFFSETS, np.zeros((2, 3)), *(np.array(
        [s * np.eye(3)[i] for s in (1, 1, -1, -1)]) for i in range(3))])        # (33, 3)
    turns = np.concatenate([np.zeros(19), [d, -d], np.tile([d, -d, d, -d], 3)])
    pts = (p[None] + h * shifts[:, None, :]).reshape(-1, 3)
    big, qs = obj.tiled(33), np.tile(q, (33, 1))
    yp, yq, meets = _unit_ball(big, pts, qs)
    lengths = np.where(meets, _ellipsoid_plane(big, pts, qs, yp, yq,
                                               (psi[None] + turns[:, None]).reshape(-1)),
                       _norm(pts - qs)).reshape(33, n)
    grad, hess = _differences(lengths[:19], h)
    l_psi_psi = (lengths[19] - 2 * lengths[0] + lengths[20]) / (d * d)
    mixed = lengths[21:].reshape(3, 4, n)
    l_p_psi = ((mixed[:, 0] - mixed[:, 1] - mixed[:, 2] + mixed[:, 3]) / (4 * h * d)).T
    bent = l_psi_psi > 0                    # ψ* a minimum (else a grazing path: ψ-free)
    hess[bent] -= (l_p_psi[bent, :, None] * l_p_psi[bent, None, :]
                   / l_psi_psi[bent, None, None])
    return lengths[0], grad, hess


def _differences(lengths: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Gradient (n, 3) and Hessian (n, 3, 3) from the lengths (19, n) at `_OFFSETS`·h."""
    n = lengths.shape[1]
    l0, plus, minus = lengths[0], lengths[1:4], lengths[4:7]
    grad = ((plus - minus) / (2 * h)).T
    hess = np.zeros((n, 3, 3))
    hess[:, range(3), range(3)] = ((plus - 2 * l0 + minus) / (h * h)).T
    k = 7
    for i in range(3):
        for j in range(i + 1, 3):
            pp, pm, mp, mm = lengths[k:k + 4]
            hess[:, i, j] = hess[:, j, i] = (pp - pm - mp + mm) / (4 * h * h)
            k += 4
    return grad, hess


def paths(obj: WrapObjects, p: np.ndarray, q: np.ndarray) -> Paths:
    """The shortest paths from the free ends P (n, 3) to the ends Q (n, 3) on the
    objects' body, over the objects `obj` (module docstring), all in that body's frame
    (mm)."""
    p, q = np.atleast_2d(np.asarray(p, float)), np.atleast_2d(np.asarray(q, float))
    length, wraps = np.empty(len(p)), np.zeros(len(p), dtype=bool)
    first, second, turn = q.copy(), p.copy(), np.zeros(len(p))
    cyl = obj.cylinder
    if cyl.any():
        part = _cylinder_paths(obj.take(cyl), p[cyl], q[cyl])
        length[cyl], wraps[cyl], first[cyl], second[cyl] = (
            part.length_mm, part.wraps, part.first, part.second)
    if (~cyl).any():
        part, turn[~cyl] = _ellipsoid(obj.take(~cyl), p[~cyl], q[~cyl])
        length[~cyl], wraps[~cyl], first[~cyl], second[~cyl] = (
            part.length_mm, part.wraps, part.first, part.second)
    return Paths(length, wraps, first, second, turn)


def length_derivatives(obj: WrapObjects, p: np.ndarray, q: np.ndarray,
                       turn: np.ndarray | None = None
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Path lengths L (n,) mm and their gradient ∇_P L (n, 3) and Hessian ∇²_P L
    (n, 3, 3, 1/mm) in the free ends P (n, 3), the objects' body frame: closed form on
    a cylinder; on an ellipsoid the envelope theorem over the plane's turn with central
    differences (`_ellipsoid_derivatives`; its plane searched from `turn`, `Paths.turn` of
    the same ends, else from the plane through the centre), the straight line's where no
    point of their stencil meets it."""
    p, q = np.atleast_2d(np.asarray(p, float)), np.atleast_2d(np.asarray(q, float))
    n = len(p)
    length, grad, hess = np.empty(n), np.empty((n, 3)), np.empty((n, 3, 3))
    cyl = obj.cylinder
    if cyl.any():
        part, g, h = _cylinder(obj.take(cyl), p[cyl], q[cyl], True)
        length[cyl], grad[cyl], hess[cyl] = part.length_mm, g, h
    ell = ~cyl
    if ell.any():           # central differences where a point of the stencil wraps
        o, pe, qe = obj.take(ell), p[ell], q[ell]
        pts = (pe[None] + STEP_MM * _OFFSETS[:, None, :]).reshape(-1, 3)
        near = _unit_ball(o.tiled(19), pts,
                          np.tile(qe, (19, 1)))[2].reshape(19, -1).any(axis=0)
        lengths, g, h = _norm(pe - qe), *_straight_derivatives(pe, qe)
        if near.any():
            lengths[near], g[near], h[near] = _ellipsoid_derivatives(
                o.take(near), pe[near], qe[near], None if turn is None else turn[ell][near])
        length[ell], grad[ell], hess[ell] = lengths, g, h
    return length, grad, hess
