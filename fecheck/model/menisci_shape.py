"""The menisci's shape: fitted to the joint (``menisci.fit``) and partly resected
(``menisci.partial``), as maps of points in the tibia frame (mm).

**Touching pose.** The femoral sheet is taken into the tibia frame at the scene's start
(the femur at the data set's pose G) and moved rigidly, along the tibia's z and, when the
tibia's abduction is free, turned about its y axis through the origin, until each
compartment's cartilages just touch: the least vertical gap from the tibial sheet's
vertices up to the femoral sheet is zero in each compartment (with abduction fixed: the
least over both). Solved by re-linearising the vertical gaps (a vertex at x gains −δz −
α x), each step's two minima matched by bisection on α, until both are below
`TOUCH_TOL_MM`. This is the unloaded joint: the meniscus is fitted where the joint
closes, not at G, where it is opened by 2.3-3 mm.

**Fit** (`fit_fields`, `FitMap`). On an x-y grid of `GRID_MM` over the meniscus and
`MARGIN_MM` around it, vertical rays give the heights of the meniscus's own inferior and
superior articular surfaces (z_i, z_s) and of the tibial cartilage (top, z_T) and the
femoral cartilage at the touching pose (bottom, z_F). Where the meniscus's surfaces and
the tibial cartilage exist, the inferior surface must move by δ_b = z_T − z_i; where the
femoral cartilage exists too and the joint space z_F − z_T is no more than the
meniscus's tallest section (max z_s − z_i: the fitted meniscus is never taller than the
shipped one, so the femur's notch and the condyles' sides, where the joint opens, are no
target), the superior must move by δ_t = z_F − z_s, the new thickness kept at least
min(its own, `MIN_THICKNESS_MM`) (the superior raised where needed: at the inner rim the
cartilages touch). Elsewhere (past a cartilage's edge, at a horn running down to bone,
under the notch) δ takes the value of the nearest grid point that has one,
times exp(−(d / `TAPER_MM`)²), d the distance to it: the shipped shape comes back
within a few mm. A point (x, y, z) of the meniscus moves vertically by (1 − s) δ_b + s
δ_t, s = (z − z_i) / (z_s − z_i) clipped to [0, 1] its relative height in the wedge
(z_i, z_s taken at the nearest grid point that has them where the surfaces do not reach):
every point keeps its x-y place (rim, horns and footprint kept) and its place in the
wedge's height. Fields are bilinear between the grid points, so every mesh of the
meniscus (volume, articular surfaces, regions, ligament points) moves by one map.

**Partial meniscectomy** (`PartialMap`). About the centre of a circle fitted (least
squares) to the volume's vertices in x-y, each vertex has an angle φ and a radius r;
over angular bins of `BIN_DEG` the least and largest radius of the volume's vertices
give the inner and outer rim r_in(φ), r_out(φ) (linear between bin centres). A point
whose radius lies in the inner third, r < r_in + (r_out − r_in) / 3, moves radially out
to that radius at its own φ and z: the inner third collapses onto a vertical cut face and
the outer two thirds are unchanged (their volume is the resected meniscus's). The
articular surfaces lose their faces with a vertex in the inner third. Near the horn
tips the radius is not across the width: there the cut follows the circle's radius.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fecheck.errors import FecheckError
from geometry.distance import ray_hits
from geometry.mesh import TriMesh

GRID_MM = 0.25
"""Spacing of the fit's x-y grid, mm."""
MARGIN_MM = 3.0
"""The grid reaches this far past the meniscus's x-y bounds, mm."""
TAPER_MM = 2.0
"""Length over which the fit's displacement fades past the cartilages' edges, mm."""
MIN_THICKNESS_MM = 0.5
"""The fitted meniscus is at least min(its own thickness, this) thick, mm."""
TOUCH_TOL_MM = 1e-4
"""The touching pose leaves each compartment's least vertical gap below this, mm."""
BIN_DEG = 10.0
"""Angular bins of the partial meniscectomy's rim radii, deg."""
_FAR_MM = 200.0


def vertical_height(mesh: TriMesh, xy: np.ndarray, from_above: bool) -> np.ndarray:
    """(n,) height z (mm) where a vertical line at each `xy` (n, 2) first meets `mesh`
    coming from above (`from_above`: its top) or from below (its bottom); NaN on a miss."""
    xy = np.asarray(xy, dtype=float)
    z0 = _FAR_MM if from_above else -_FAR_MM
    origins = np.column_stack([xy, np.full(len(xy), z0)])
    direction = np.array([0.0, 0.0, -1.0 if from_above else 1.0])
    d = ray_hits(origins, np.tile(direction, (len(xy), 1)), mesh)[0]
    z = z0 + direction[2] * d
    return np.where(np.isfinite(d), z, np.nan)


def _moved(points: np.ndarray, alpha: float, dz: float) -> np.ndarray:
    c, s = math.cos(alpha), math.sin(alpha)
    rot = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    return points @ rot.T - [0.0, 0.0, dz]


def _match(gaps: list[np.ndarray], xs: list[np.ndarray]) -> float:
    """The turn α (rad) at which the linearised least gaps min(g − α x) of the two
    compartments are equal (bisection; the medial one grows with α, the lateral falls)."""
    def diff(a: float) -> float:
        m = [float((g - a * x).min()) for g, x in zip(gaps, xs, strict=True)]
        return m[0] - m[1]

    lo, hi = -0.3, 0.3
    if diff(lo) * diff(hi) > 0:
        raise FecheckError("menisci.fit: no turn about y within ±17 deg makes both "
                           "compartments' cartilages touch; use menisci.fit = 'as-shipped'")
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if diff(lo) * diff(mid) <= 0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def touching_femur(femur: TriMesh, tibia: dict[str, TriMesh], turn: bool
                   ) -> tuple[TriMesh, float, float]:
    """(the femoral sheet at the touching pose, its turn α about y (rad), its drop along
    z (mm)): `femur` and `tibia` ({compartment: sheet}) in the tibia frame (module
    docstring). `turn`: also turn about y (the tibia's abduction is free)."""
    names = sorted(tibia)
    alpha, dz = 0.0, 0.0
    for _ in range(20):
        moved = TriMesh(_moved(femur.points, alpha, dz), femur.faces)
        gaps, xs = [], []
        for c in names:
            pts = tibia[c].points
            top = vertical_height(moved, pts[:, :2], from_above=False)
            hit = np.isfinite(top)
            if not hit.any():
                raise FecheckError(f"menisci.fit: no part of the {c} tibial cartilage lies "
                                   "under the femoral cartilage; use menisci.fit = "
                                   "'as-shipped'")
            gaps.append(top[hit] - pts[hit, 2])
            xs.append(pts[hit, 0])
        least = [float(g.min()) for g in gaps]
        if max(abs(v) for v in least) <= TOUCH_TOL_MM or (not turn and min(least) >= 0
                                                            and min(least) <= TOUCH_TOL_MM):
            return moved, alpha, dz
        if turn and len(names) == 2:
            order = [names.index(c) for c in ("medial", "lateral")]
            da = _match([gaps[i] for i in order], [xs[i] for i in order])
            dd = min(float((g - da * x).min()) for g, x in zip(gaps, xs, strict=True))
        else:
            da, dd = 0.0, min(least)
        alpha, dz = alpha + da, dz + dd
    raise FecheckError("menisci.fit: the touching pose did not settle in 20 steps; use "
                       "menisci.fit = 'as-shipped'")


@dataclass(frozen=True, eq=False)
class FitMap:
    """The fit's vertical map (module docstring): grid origin (2,) and spacing (mm), and
    on the grid (ny, nx) the meniscus's own inferior and superior heights z_i, z_s and
    the displacements δ_b, δ_t (mm)."""

    origin: np.ndarray
    spacing: float
    z_inf: np.ndarray
    z_sup: np.ndarray
    d_bottom: np.ndarray
    d_top: np.ndarray

    def _sample(self, field: np.ndarray, xy: np.ndarray) -> np.ndarray:
        from scipy.ndimage import map_coordinates

        ij = ((xy - self.origin) / self.spacing)[:, ::-1].T
        return map_coordinates(field, ij, order=1, mode="nearest")

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """`points` (n, 3) mm moved vertically by the fit."""
        p = np.asarray(points, dtype=float)
        xy = p[:, :2]
        zi, zs = self._sample(self.z_inf, xy), self._sample(self.z_sup, xy)
        s = np.clip((p[:, 2] - zi) / np.maximum(zs - zi, 1e-9), 0.0, 1.0)
        out = p.copy()
        out[:, 2] += (1.0 - s) * self._sample(self.d_bottom, xy) + s * self._sample(
            self.d_top, xy)
        return out


def _fill(field: np.ndarray, valid: np.ndarray, spacing: float, taper_mm: float | None
          ) -> np.ndarray:
    """`field` with each invalid grid point given its nearest valid one's value (times
    exp(−(d / taper_mm)²), d the distance to it, mm, when `taper_mm` is given)."""
    from scipy.ndimage import distance_transform_edt

    if not valid.any():
        raise FecheckError("menisci.fit: a meniscus surface lies over no cartilage")
    dist, idx = distance_transform_edt(~valid, return_indices=True)
    out = field[idx[0], idx[1]]
    if taper_mm is not None:
        out = out * np.exp(-(dist * spacing / taper_mm) ** 2)
    return out


def fit_fields(volume: TriMesh, inferior: TriMesh, superior: TriMesh, tibia: TriMesh,
               femur: TriMesh, *, spacing: float = GRID_MM) -> FitMap:
    """The `FitMap` seating the meniscus (its closed `volume`, articular `inferior` and
    `superior` surfaces) between the `tibia`'s top and the `femur`'s bottom (all in one
    frame, z the tibia's axis, mm; module docstring)."""
    lo = volume.points[:, :2].min(axis=0) - MARGIN_MM
    hi = volume.points[:, :2].max(axis=0) + MARGIN_MM
    nx, ny = (np.ceil((hi - lo) / spacing).astype(int) + 1)
    gx, gy = np.meshgrid(lo[0] + spacing * np.arange(nx), lo[1] + spacing * np.arange(ny))
    xy = np.column_stack([gx.ravel(), gy.ravel()])
    heights = [vertical_height(inferior, xy, False), vertical_height(superior, xy, True),
               vertical_height(tibia, xy, True), vertical_height(femur, xy, False)]
    zi, zs, zt, zf = (h.reshape(ny, nx) for h in heights)
    own = np.isfinite(zi) & np.isfinite(zs)
    zi_f, zs_f = _fill(zi, np.isfinite(zi), spacing, None), _fill(zs, np.isfinite(zs),
                                                                  spacing, None)
    db, dt = zt - zi_f, zf - zs_f
    thick = zs_f - zi_f
    tallest = float(np.nanmax(np.where(own, thick, np.nan)))
    both = own & np.isfinite(zt) & np.isfinite(zf) & (zf - zt <= tallest)
    least = zi_f + db + np.minimum(np.maximum(thick, 0.0), MIN_THICKNESS_MM)
    dt = np.where(both, np.maximum(dt, least - zs_f), dt)
    bottom = own & np.isfinite(zt)
    return FitMap(lo, spacing, zi_f, zs_f,
                  _fill(np.where(bottom, db, 0.0), bottom, spacing, TAPER_MM),
                  _fill(np.where(both, dt, 0.0), both, spacing, TAPER_MM))


@dataclass(frozen=True, eq=False)
class PartialMap:
    """The partial meniscectomy's radial map (module docstring): centre (2,) mm, bin
    centres (b,) rad and the inner and outer rim radii there (mm)."""

    centre: np.ndarray
    angles: np.ndarray
    r_in: np.ndarray
    r_out: np.ndarray

    def polar(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(φ rad, r mm, the cut radius mm at φ) of `points` (n, 3)."""
        d = np.asarray(points, dtype=float)[:, :2] - self.centre
        phi = np.arctan2(d[:, 1], d[:, 0])
        r = np.linalg.norm(d, axis=1)
        period = 2.0 * np.pi
        r_in = np.interp(phi, self.angles, self.r_in, period=period)
        r_out = np.interp(phi, self.angles, self.r_out, period=period)
        return phi, r, r_in + (r_out - r_in) / 3.0

    def inner(self, points: np.ndarray) -> np.ndarray:
        """(n,) bool: the points in the resected inner third."""
        _, r, cut = self.polar(points)
        return r < cut

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """`points` (n, 3) mm with those in the inner third moved out to the cut."""
        p = np.asarray(points, dtype=float).copy()
        phi, r, cut = self.polar(p)
        move = r < cut
        p[move, 0] = self.centre[0] + cut[move] * np.cos(phi[move])
        p[move, 1] = self.centre[1] + cut[move] * np.sin(phi[move])
        return p


def fit_circle(xy: np.ndarray) -> np.ndarray:
    """Centre (2,) of the least-squares circle through the points `xy` (n, 2) (Kåsa)."""
    a = np.column_stack([2.0 * xy, np.ones(len(xy))])
    sol = np.linalg.lstsq(a, (xy ** 2).sum(axis=1), rcond=None)[0]
    return sol[:2]


def partial_map(volume: TriMesh) -> PartialMap:
    """The `PartialMap` of the closed meniscus `volume` (module docstring)."""
    pts = volume.points
    centre = fit_circle(pts[:, :2])
    d = pts[:, :2] - centre
    phi, r = np.arctan2(d[:, 1], d[:, 0]), np.linalg.norm(d, axis=1)
    width = math.radians(BIN_DEG)
    which = np.floor((phi + np.pi) / width).astype(int)
    bins = np.unique(which)
    r_in = np.array([r[which == b].min() for b in bins])
    r_out = np.array([r[which == b].max() for b in bins])
    angles = -np.pi + (bins + 0.5) * width
    return PartialMap(centre, angles, r_in, r_out)


def drop_inner(sheet: TriMesh, cut: PartialMap) -> TriMesh:
    """`sheet` without its faces that have a vertex in the resected inner third."""
    keep = ~cut.inner(sheet.points)[sheet.faces].any(axis=1)
    used = np.unique(sheet.faces[keep])
    index = np.full(len(sheet.points), -1)
    index[used] = np.arange(len(used))
    return TriMesh(sheet.points[used], index[sheet.faces[keep]])
