"""Rigid indenters for the FE layer: the gap along each surface vertex's normal, and how it
changes when the layer's body moves.

The gap of a layer vertex p with outward unit normal n is the distance s along the ray
p + s·n to the indenter's surface (negative: the vertex is inside the indenter by that
much along n) — the EF convention of depth along the foundation normal. Where the ray
hits the indenter at y = p + s·n with indenter normal m, moving the layer's body by the
twist ξ = (v, ω) (δp = v + ω × p, δn = ω × n) changes it by
ds = −(m·v + ω·(y × m)) / (m·n), the row `twist` (6,) of each vertex.

Units: mm; everything in one frame (the femur's, i.e. the world).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fecheck.contact.kernels import rim_weights, sphere_ray_roots
from fecheck.errors import FecheckError
from geometry.distance import ray_hits
from geometry.mesh import TriMesh

FAR_MM = 1.0e3
"""The gap given to a vertex whose normal ray misses the indenter, mm."""


@dataclass(frozen=True, eq=False)
class Gap:
    """Gaps s (m,) mm along the vertex normals and their twist rows (m, 6), mm per
    (mm, rad); rows are zero where the ray misses (gap `FAR_MM`)."""

    gap_mm: np.ndarray
    twist: np.ndarray


def _twist_rows(points: np.ndarray, normals: np.ndarray, s: np.ndarray, m: np.ndarray,
                hit: np.ndarray) -> np.ndarray:
    y = points + s[:, None] * normals
    cos = np.einsum("ij,ij->i", m, normals)
    rows = np.zeros((len(points), 6))
    ok = hit & (np.abs(cos) > 1e-6)
    rows[ok, :3] = -m[ok] / cos[ok, None]
    rows[ok, 3:] = -np.cross(y[ok], m[ok]) / cos[ok, None]
    return rows


@dataclass(frozen=True)
class SphereIndenter:
    """A rigid sphere, centre (3,) mm and radius mm (an analytic femoral condyle)."""

    center: np.ndarray
    radius_mm: float

    def describe(self) -> str:
        return f"rigid sphere R {self.radius_mm:.2f} mm"

    def gap(self, points: np.ndarray, normals: np.ndarray) -> Gap:
        """Gap along `normals` from `points` to the sphere (the near intersection)."""
        center = np.asarray(self.center, dtype=float)
        s, hit = sphere_ray_roots(np.ascontiguousarray(points, dtype=float),
                                  np.ascontiguousarray(normals, dtype=float), center,
                                  float(self.radius_mm))
        s = np.where(hit, s, FAR_MM)
        m = (points - center + s[:, None] * normals) / self.radius_mm
        return Gap(s, _twist_rows(points, normals, s, m, hit))


@dataclass(frozen=True, eq=False)
class MeshIndenter:
    """A rigid triangle surface (a scanned femoral cartilage sheet; outward normals, i.e.
    facing the tibia).

    Only faces that face the vertex count (m·n < 0): a vertex is outside where such a face
    is hit ahead (along n), inside where one is hit behind (along −n, the vertex went
    through it); where both, the nearer one decides. Open sheets work. A face hit
    behind farther than `max_depth_mm` does not count (the ray crossed the layer's own
    body and met the far side of a curved surface, as a patellar vertex's can the
    trochlea's).

    `rim` = (the distance of each face's corners to the sheet's open rim (n_faces, 3) mm,
    `fecheck.contact.mesh_master.MeshMaster.rim_distance`; the fade's width mm) fades
    contact at the rim as the EF's pair does (`fecheck.contact.pair.ContactPair`'s
    rim_mm): a penetration s < 0 whose hit point lies at φ (interpolated over the face)
    from the rim counts as w(φ)·s (`fecheck.contact.kernels.rim_weight`: 0 on the rim, 1
    from the width in), the EF's faded depth, so the surface recedes by (1 − w)·|s| and
    a vertex whose hit slides off the rim meets no step in its gap; a positive gap is
    kept (w·s would close an open gap at the rim). Counting a hit in the band as a miss
    would only move the step from the rim to the band's inner edge: at full size a
    patellar vertex whose ray crossed the rim at 90° flipped between a miss and a 0.35 mm
    penetration at every pose update and the pose cycled; with the fade it settles in 6.
    Width 0: no fade.
    """

    mesh: TriMesh
    max_depth_mm: float = math.inf
    rim: tuple[np.ndarray, float] = (np.zeros((0, 3)), 0.0)

    def __post_init__(self) -> None:
        if self.rim[1] > 0.0 and np.shape(self.rim[0]) != (self.mesh.n_faces, 3):
            raise FecheckError(f"the rim table has shape {np.shape(self.rim[0])}, not one "
                               f"row per face of the indenter ({self.mesh.n_faces}, 3)")

    def describe(self) -> str:
        return f"rigid mesh ({self.mesh.n_faces} faces)"

    def gap(self, points: np.ndarray, normals: np.ndarray) -> Gap:
        """Gap along `normals` from `points` to the mesh."""
        return self.hits(points, normals)[0]

    def hits(self, points: np.ndarray, normals: np.ndarray
             ) -> tuple[Gap, np.ndarray, np.ndarray]:
        """The `gap`, the face each ray hits (m,) (-1: a miss) and the hit point's
        barycentric weights (m, 3) on that face's vertices (zero on a miss)."""
        fn = self.mesh.face_normals
        ahead, face_a = ray_hits(points, normals, self.mesh, facing=-normals)
        behind, face_b = ray_hits(points, -normals, self.mesh, facing=-normals)
        use_behind = ((face_b >= 0) & (behind <= self.max_depth_mm)
                      & ((face_a < 0) | (behind < ahead)))
        s = np.where(use_behind, -behind, np.where(face_a >= 0, ahead, FAR_MM))
        face = np.where(use_behind, face_b, face_a)
        hit = face >= 0
        if not np.all(np.isfinite(s)):
            raise FecheckError("indenter gaps are not finite: check the femoral mesh")
        corners = self.mesh.points[self.mesh.faces[np.maximum(face, 0)]]
        y = points + s[:, None] * normals
        weights = barycentric(corners, y[:, None, :])[:, 0] * hit[:, None]
        rows = _twist_rows(points, normals, s, fn[np.maximum(face, 0)], hit)
        if self.rim[1] > 0.0:
            s, rows = _rim_faded(s, rows, hit, corners, weights, y, normals,
                                 self.rim[0][np.maximum(face, 0)], self.rim[1])
        return Gap(s, rows), face, weights


def _rim_faded(s: np.ndarray, rows: np.ndarray, hit: np.ndarray, corners: np.ndarray,
               weights: np.ndarray, y: np.ndarray, normals: np.ndarray, rim: np.ndarray,
               rim_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Gaps s (m,) and twist rows (m, 6) of rays hitting at y (m, 3) on faces with
    `corners` (m, 3, 3), barycentric `weights` (m, 3) and corner rim distances `rim`
    (m, 3) mm, faded (`MeshIndenter`): w(φ)·s where s < 0, its row w·ds + s·w'·dφ. The
    hit point moves by dy = v + ω × y + ds·n on the face, so dφ = ∇φ·dy with ∇φ the
    in-plane gradient of φ over the face."""
    w, dw = rim_weights(np.einsum("ij,ij->i", weights, rim), rim_mm)
    fade = hit & (s < 0.0) & (w < 1.0)
    if not fade.any():
        return s, rows
    ab, ac = corners[fade, 1] - corners[fade, 0], corners[fade, 2] - corners[fade, 0]
    g11, g22 = np.einsum("ij,ij->i", ab, ab), np.einsum("ij,ij->i", ac, ac)
    g12 = np.einsum("ij,ij->i", ab, ac)
    det = g11 * g22 - g12 * g12
    p1, p2 = rim[fade, 1] - rim[fade, 0], rim[fade, 2] - rim[fade, 0]
    grad = (((g22 * p1 - g12 * p2) / det)[:, None] * ab
            + ((g11 * p2 - g12 * p1) / det)[:, None] * ac)
    d_phi = (np.hstack([grad, np.cross(y[fade], grad)])
             + np.einsum("ij,ij->i", grad, normals[fade])[:, None] * rows[fade])
    s, rows = s.copy(), rows.copy()
    rows[fade] = w[fade, None] * rows[fade] + (s[fade] * dw[fade])[:, None] * d_phi
    s[fade] = w[fade] * s[fade]
    return s, rows


def barycentric(tri: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (m, k, 3) of points pts (m, k, 3) in triangles (m, 3, 3)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1 = b - a, c - a
    d00 = np.einsum("ij,ij->i", v0, v0)
    d01 = np.einsum("ij,ij->i", v0, v1)
    d11 = np.einsum("ij,ij->i", v1, v1)
    den = d00 * d11 - d01 * d01
    v2 = pts - a[:, None]
    d20 = np.einsum("mkj,mj->mk", v2, v0)
    d21 = np.einsum("mkj,mj->mk", v2, v1)
    v = (d11[:, None] * d20 - d01[:, None] * d21) / den[:, None]
    w = (d00[:, None] * d21 - d01[:, None] * d20) / den[:, None]
    return np.stack([1.0 - v - w, v, w], axis=2)
