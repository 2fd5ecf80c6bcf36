"""GJK distance and EPA penetration for convex shapes given by support functions (mm).

Thesis §3.2.3, Algorithms 1-2. The Minkowski difference C = A ⊖ B is explored through
its support mapping s_C(d) = s_A(d) - s_B(-d) (eq. 3.5): A and B overlap iff the origin
lies in C. GJK finds the point of C closest to the origin (the distance and witness
points when separated); EPA expands GJK's final simplex into a polytope until its
face nearest the origin lies on the boundary of C (the penetration depth and normal).

Shapes are a convex core plus a margin radius: a sphere is its centre with margin R,
so GJK/EPA run on points and polytopes only (finite termination) and sphere results
are exact. Kept in the tests as an independent reference for the closed-form sphere-plane
point contact of the Hertz law (`tests/contact/test_hertz_point.py`): no scene path uses it. Plain
Python over at most a few hundred vertices.

>>> depth, normal = max_penetration(SphereShape([0, 0, 0], 1.0), SphereShape([1.5, 0, 0], 1.0))
>>> round(depth, 12), (normal.round(12) + 0.0).tolist()
(0.5, [1.0, 0.0, 0.0])
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from fecheck.errors import FecheckError

_TOL = 1e-10


@dataclass(frozen=True, eq=False)
class ConvexPoints:
    """The convex hull of `points` (n, 3), mm."""

    points: np.ndarray
    margin: float = 0.0

    def __post_init__(self) -> None:
        p = np.asarray(self.points, dtype=float)
        if p.ndim != 2 or p.shape[1] != 3 or len(p) == 0 or not np.isfinite(p).all():
            raise FecheckError("a convex shape needs a non-empty (n, 3) array of finite points")
        object.__setattr__(self, "points", p)

    def support(self, d: np.ndarray) -> np.ndarray:
        return self.points[np.argmax(self.points @ d)]


@dataclass(frozen=True, eq=False)
class SphereShape:
    """A ball: its centre (mm) as the core, its radius (mm) as the margin."""

    center: np.ndarray
    radius: float

    def __post_init__(self) -> None:
        c = np.asarray(self.center, dtype=float)
        if c.shape != (3,) or not np.isfinite(c).all() or not self.radius > 0:
            raise FecheckError("a sphere needs a finite centre (3,) and a positive radius (mm)")
        object.__setattr__(self, "center", c)

    @property
    def margin(self) -> float:
        return float(self.radius)

    def support(self, d: np.ndarray) -> np.ndarray:
        return self.center


def BoxShape(center, half_extents, rotation=None) -> ConvexPoints:
    """A box of `half_extents` (mm) about `center`, axes the columns of `rotation`."""
    h = np.asarray(half_extents, dtype=float)
    if h.shape != (3,) or not np.all(h >= 0):
        raise FecheckError("box half extents must be 3 non-negative lengths (mm)")
    R = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    return ConvexPoints((signs * h) @ R.T + np.asarray(center, dtype=float))


@dataclass(frozen=True)
class GJKResult:
    """overlap; distance (mm, 0 if overlapping); depth (mm, 0 if separated); unit
    normal pointing from A towards B (moving B by depth·normal separates them);
    witness points on A and B (mm): the closest points, or the deepest points."""

    overlap: bool
    distance: float
    depth: float
    normal: np.ndarray
    point_a: np.ndarray
    point_b: np.ndarray


def _support(a, b, d):
    pa, pb = a.support(d), b.support(-d)
    return pa - pb, pa, pb


def _closest_on_simplex(W: list[np.ndarray]):
    """Point of the simplex hull closest to the origin: (point, subset, barycentric)."""
    best = None
    for k in range(len(W), 0, -1):
        for subset in combinations(range(len(W)), k):
            P = np.array([W[i] for i in subset])
            if k == 1:
                lam = np.ones(1)
            else:
                E = P[1:] - P[0]
                G = E @ E.T
                if abs(np.linalg.det(G)) < 1e-14 * max(1.0, np.abs(G).max()) ** (k - 1):
                    continue
                mu = np.linalg.solve(G, -E @ P[0])
                lam = np.concatenate([[1.0 - mu.sum()], mu])
            if np.all(lam >= -1e-12):
                x = lam @ P
                if best is None or x @ x < best[0] @ best[0] - 1e-15:
                    best = (x, subset, lam)
    return best


def _gjk(a, b, max_iter: int = 100):
    """Core GJK: (closest point v of C to the origin, simplex (C, A, B points), λ)."""
    d = np.array([1.0, 0.0, 0.0])
    w, pa, pb = _support(a, b, d)
    W, A, B, lam = [w], [pa], [pb], np.ones(1)
    v = w
    for _ in range(max_iter):
        vv = v @ v
        if vv < _TOL**2:
            break
        w, pa, pb = _support(a, b, -v)
        if vv - v @ w <= 1e-12 * max(vv, 1.0):
            break                                             # no progress: v is closest
        W.append(w), A.append(pa), B.append(pb)
        v, subset, lam = _closest_on_simplex(W)
        W, A, B = [W[i] for i in subset], [A[i] for i in subset], [B[i] for i in subset]
        if len(W) == 4:
            break                                             # origin inside the tetrahedron
    return v, W, A, B, lam


def _blow_up(a, b, W, A, B):
    """Grow a degenerate terminating simplex into a tetrahedron of C points."""
    axes = np.eye(3)
    for d in np.concatenate([axes, -axes]):
        if len(W) >= 4:
            break
        w, pa, pb = _support(a, b, d)
        trial = W + [w]
        P = np.array(trial)
        if np.linalg.matrix_rank(P[1:] - P[0], tol=1e-9) == len(trial) - 1:
            W, A, B = trial, A + [pa], B + [pb]
    if len(W) == 3:
        n = np.cross(W[1] - W[0], W[2] - W[0])
        for d in (n, -n):
            w, pa, pb = _support(a, b, d)
            if abs((w - W[0]) @ n) > 1e-9 * np.linalg.norm(n):
                W, A, B = W + [w], A + [pa], B + [pb]
                break
    return W, A, B


def _epa(a, b, W, A, B, max_iter: int = 200):
    """Penetration of the cores: (depth, outward normal of C, witness on A, on B)."""
    W, A, B = _blow_up(a, b, list(W), list(A), list(B))
    if len(W) < 4:                           # C is flat: the cores only touch
        return 0.0, None, A[0], B[0]
    pts, pa, pb = list(W), list(A), list(B)
    faces = [(0, 1, 2), (0, 3, 1), (0, 2, 3), (1, 3, 2)]
    centre = np.mean(pts, axis=0)

    def oriented(f):
        i, j, k = f
        n = np.cross(pts[j] - pts[i], pts[k] - pts[i])
        return (i, k, j) if n @ (pts[i] - centre) < 0 else f

    faces = [oriented(f) for f in faces]
    for _ in range(max_iter):
        normals, dists = [], []
        for i, j, k in faces:
            n = np.cross(pts[j] - pts[i], pts[k] - pts[i])
            n /= np.linalg.norm(n)
            normals.append(n)
            dists.append(n @ pts[i])
        f = int(np.argmin(dists))
        n, dist = normals[f], dists[f]
        w, wa, wb = _support(a, b, n)
        if w @ n - dist < 1e-9 * max(1.0, abs(dist)):
            i, j, k = faces[f]
            P = np.array([pts[i], pts[j], pts[k]])
            E = P[1:] - P[0]
            mu = np.linalg.lstsq(E.T, dist * n - P[0], rcond=None)[0]
            lam = np.array([1.0 - mu.sum(), mu[0], mu[1]])
            return (max(dist, 0.0), n, lam @ np.array([pa[i], pa[j], pa[k]]),
                    lam @ np.array([pb[i], pb[j], pb[k]]))
        visible = [fc for fc, nn in zip(faces, normals, strict=True)
                   if nn @ (w - pts[fc[0]]) > 1e-12]
        edges: dict[tuple[int, int], int] = {}
        for i, j, k in visible:
            for e in ((i, j), (j, k), (k, i)):
                if (e[1], e[0]) in edges:
                    del edges[(e[1], e[0])]
                else:
                    edges[e] = 1
        pts.append(w), pa.append(wa), pb.append(wb)
        new = len(pts) - 1
        faces = [fc for fc in faces if fc not in visible] + [(i, j, new) for i, j in edges]
    raise FecheckError("EPA did not converge; check that the shapes are convex and finite")


def gjk_epa(shape_a, shape_b) -> GJKResult:
    """Distance or penetration between two convex shapes (mm), see `GJKResult`."""
    v, W, A, B, lam = _gjk(shape_a, shape_b)
    ra, rb = shape_a.margin, shape_b.margin
    core = float(np.linalg.norm(v))
    if core > 1e-9 and len(W) < 4:
        ca, cb = lam @ np.array(A), lam @ np.array(B)
        n = -v / core                                       # from A towards B
        gap = core - ra - rb
        pa, pb = ca + ra * n, cb - rb * n
        if gap > 0:
            return GJKResult(False, gap, 0.0, n, pa, pb)
        return GJKResult(True, 0.0, -gap, n, pa, pb)
    depth, n, ca, cb = _epa(shape_a, shape_b, W, A, B)
    if n is None:                                           # flat contact of the cores
        n = np.zeros(3)
    return GJKResult(True, 0.0, depth + ra + rb, n, ca + ra * n, cb - rb * n)


def max_penetration(shape_a, shape_b) -> tuple[float, np.ndarray]:
    """(depth mm ≥ 0, unit normal from A towards B); depth 0 when separated."""
    r = gjk_epa(shape_a, shape_b)
    return r.depth, r.normal
