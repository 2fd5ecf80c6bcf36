"""Hertz laws (thesis eq. 4.4-4.8): the force from the maximum depth d only.

P = 4/3·E*·√R·d^{3/2}; E* from `fecheck.laws.materials.hertz_modulus`; a = √(R d),
p0 = 3P/(2πa²), each written once in `fecheck.reference.closed_forms`. `hertz_point`
takes d from a convex point contact (`fecheck.contact.convex`, smooth in the pose);
`hertz` from the deepest vertex of a meshed slave, which is NOT smooth (the deepest
vertex switches as the slave tilts, and Newton may stall): it is kept for polynomial
plateaus and mesh detection.
"""

from __future__ import annotations

import math

import numpy as np

from fecheck.contact.convex import PointContact
from fecheck.contact.surface import ContactSurface
from fecheck.errors import FecheckError
from fecheck.laws.kernel import NO_CLIP, NO_SLIDE, pressure_resultant
from fecheck.laws.result import LawResult, no_contact
from fecheck.reference.closed_forms import hertz_load, hertz_peak_pressure, hertz_radius_at_depth


def _deepest_vertex(surface: ContactSurface) -> tuple[int, np.ndarray, float, np.ndarray]:
    """(contact face, world position, depth, d depth/dξ) of the deepest slave vertex."""
    flat = int(np.argmax(surface.vertex_depth))
    face, corner = divmod(flat, 3)
    depth = float(surface.vertex_depth[face, corner])
    rows = np.flatnonzero(surface.qp_face == face)
    bary = surface.qp_bary[rows]
    sol, *_ = np.linalg.lstsq(bary, np.column_stack([surface.qp_point[rows],
                                                      surface.qp_depth_twist[rows],
                                                      surface.qp_depth[rows]]), rcond=None)
    point = sol[corner, :3]
    if np.allclose(surface.qp_depth[rows], depth, rtol=0, atol=1e-12 * max(1.0, depth)):
        twist = surface.qp_depth_twist[rows[0]]        # whole-face mode: depth is the max
    else:
        twist = sol[corner, 3:9]
    return face, point, depth, twist


def hertz(surface: ContactSurface, radius_mm: float, e_star_MPa: float,
          about=(0.0, 0.0, 0.0)) -> LawResult:
    """Hertz law from the deepest slave vertex (eq. 4.4-4.8): P = 4/3·E*·√R·d^{3/2} (N).

    The force acts along the foundation normal of the deepest face at the deepest
    vertex. Not smooth in the pose: the deepest vertex switches as the slave tilts, so
    Newton may stall; use `hertz_point` on a convex pair where there is one.
    `radius_mm` is the indenter radius R, `e_star_MPa` from `hertz_modulus`.
    Reports a = √(R d) (mm), p0 = 3P/(2πa²), mean pressure P/(πa²) and area πa².
    """
    about = np.asarray(about, dtype=float)
    if surface.n_faces == 0 or surface.max_depth <= 0:
        return no_contact(surface, about)
    r = float(radius_mm)
    face, x, d, dd = _deepest_vertex(surface)
    n = surface.normal[face]
    load = hertz_load(d, r, e_star_MPa)
    a = hertz_radius_at_depth(d, r)
    p0 = hertz_peak_pressure(load, a)
    slide = surface.normal_slide
    _, force, moment, tangent, _ = pressure_resultant(
        0.0, np.array([load]), np.array([1.5 * load / d]), np.array([d]), np.ones(1),
        np.array([dd]), np.zeros((1, 6)), np.array([x]), np.array([n]),
        np.zeros(1, dtype=np.int64), surface.normal_body == "slave",
        NO_SLIDE if slide is None else slide[face:face + 1], *NO_CLIP, about)
    centroids = surface.face_sum(surface.qp_point) / np.bincount(
        surface.qp_face, minlength=surface.n_faces)[:, None]

    def face_pressure() -> np.ndarray:
        rel = centroids - x
        rel -= np.outer(rel @ n, n)
        ratio = 1.0 - np.einsum("ij,ij->i", rel, rel) / (a * a)
        out = np.zeros(surface.n_slave_faces)
        out[surface.face] = p0 * np.sqrt(np.clip(ratio, 0.0, None))
        return out

    return LawResult(surface, np.zeros(len(surface.qp_depth)), force, moment, tangent, p0,
                     math.pi * a * a, d, a, face_pressure_fn=face_pressure)


def hertz_point(contact: PointContact, radius_mm: float, e_star_MPa: float,
                about=(0.0, 0.0, 0.0)) -> LawResult:
    """Hertz law on a convex point contact (eq. 4.4-4.8), smooth in the pose.

    F = P(d)·u (N) with P = 4/3·E*·√R·d^{3/2}, d = `contact.depth_mm`, u =
    `contact.direction`; M = (c − about) × F (N·mm), c = `contact.point` (fixed in the
    master). Exact tangent: dF = P'(d)·u ⊗ ∂d/∂ξ + P·∂u/∂ξ, dM = (c − about) × dF.
    Reports a = √(R d) (mm), p0 = 3P/(2πa²) (MPa, `max_pressure`), mean pressure
    P/(πa²) and area πa²; `face_pressure()` draws p0·√(1 − r²/a²) (r from the line of
    action) on the faces of `contact.face_centroids`, evaluated only when asked.
    """
    about = np.asarray(about, dtype=float)
    d = float(contact.depth_mm)
    if math.isnan(d):
        raise FecheckError("the contact depth is NaN; check the poses passed to the pair")
    centroids = contact.face_centroids

    def no_mesh() -> np.ndarray:
        raise FecheckError("this point contact has no slave mesh to draw the pressure on; "
                           "give the pair a mesh")

    z3 = np.zeros(3)
    if d <= 0:
        return LawResult(contact, np.zeros(0), z3, z3.copy(), np.zeros((6, 6)), 0.0, 0.0, 0.0,
                         face_pressure_fn=no_mesh if centroids is None
                         else lambda: np.zeros(len(centroids())))
    r = float(radius_mm)
    u, c = contact.direction, contact.point
    load = hertz_load(d, r, e_star_MPa)
    force = load * u
    arm = c - about
    moment = np.cross(arm, force)
    dforce = np.outer(u, 1.5 * load / d * contact.depth_twist) + load * contact.direction_twist
    tangent = np.vstack([dforce, np.cross(arm, dforce, axisa=0, axisb=0, axisc=0)])
    a = hertz_radius_at_depth(d, r)
    area = math.pi * a * a
    p0 = hertz_peak_pressure(load, a)

    def face_pressure() -> np.ndarray:
        rel = centroids() - c
        rel -= np.outer(rel @ u, u)
        ratio = 1.0 - np.einsum("ij,ij->i", rel, rel) / (a * a)
        return p0 * np.sqrt(np.clip(ratio, 0.0, None))

    return LawResult(contact, np.zeros(0), force, moment, tangent, p0, area, d, a,
                     face_pressure_fn=no_mesh if centroids is None else face_pressure)

