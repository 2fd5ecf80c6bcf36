"""Contact laws: a `ContactSurface` → pressure, resultant wrench and its exact tangent.

Every law returns a `LawResult`: the pressure at each quadrature point (MPa), the force
F (N) and moment M (N·mm, about a given point) that the master exerts on the SLAVE, and
the tangent d[F, M]/dξ (6, 6) with respect to the twist ξ = (v, ω) of the slave relative
to the master (see `fecheck.contact.surface`). The tangent is exact for the discrete
model: chain rule through ``qp_depth_twist``, ``qp_weight_twist``, the motion of the
points ``δx = v + ω × x`` and the motion of the normals ``normal_twist``.

Laws (thesis chapter 4):

* `elastic_foundation` (eq. 4.1-4.3): p = k·d, k = (1−ν)E / ((1+ν)(1−2ν)h) (N/mm³).
* `volumetric` (eq. 4.9): F = k_V·V (1 + a·v_n) with v_n = 0 in statics, i.e. p = k_V·d.
  The thesis's k_V ≈ 1e7 N/m³ is 1e-2 N/mm³ (1 m³ = 1e9 mm³), about 450 times softer
  than the baseline EF foundation (4.487 N/mm³).
* `blankevoort_foundation`: the nonlinear foundation of Blankevoort et al. 1991
  (J. Biomech. 24(11):1019-1031, eq. for the cartilage layer),
  p = −(1−ν)E/((1+ν)(1−2ν)) · ln(1 − d/h). It stiffens without bound as d → h; beyond
  d = 0.9·h it is continued linearly (C¹) so that a Newton iterate that overshoots stays
  finite (the equilibrium itself is reported with its depth; d > 0.9 h is flagged).
* Hertz (eq. 4.4-4.8): from the maximum depth d only, P = 4/3·E*·√R·d^{3/2}; E* = E/(1−ν²)
  for a rigid indenter or 1/E* = Σ (1−ν_i²)/E_i for two deformable bodies; a = √(R d),
  p0 = 3P/(2πa²). `hertz_point` takes d from a convex point contact
  (`fecheck.contact.convex`, smooth in the pose); `hertz` from the deepest vertex of a
  meshed slave, which is NOT smooth (the deepest vertex switches as the slave tilts, and
  Newton may stall): it is kept for polynomial plateaus and mesh detection.

>>> round(ef_stiffness(20.0, 0.3, 6.0), 4)
4.4872
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from fecheck.contact.convex import PointContact
from fecheck.contact.surface import ContactSurface
from fecheck.errors import FecheckError
from fecheck.law_kernel import NO_SLIDE, NO_VALUES, pressure_resultant

BLANKEVOORT_LINEAR_FROM = 0.9      # fraction of h beyond which the log law is continued linearly


def _check_number(name: str, value: float) -> float:
    value = float(value)
    if math.isnan(value):
        raise FecheckError(f"{name} is NaN; give a number")
    return value


def validate_material(youngs_MPa: float, poisson: float, thickness_mm: float | None = None
                      ) -> None:
    """Reject E ≤ 0, h ≤ 0, ν < 0, ν ≥ 0.5 and NaN (`FecheckError`); warn when ν > 0.49."""
    e = _check_number("Young's modulus (contact.youngs_MPa)", youngs_MPa)
    nu = _check_number("Poisson's ratio (contact.poisson)", poisson)
    if not e > 0:
        raise FecheckError(f"Young's modulus must be > 0 MPa, got {e:g}")
    if nu >= 0.5:
        raise FecheckError(f"Poisson's ratio {nu:g} ≥ 0.5: the EF stiffness diverges as "
                           f"ν → 0.5 (1 − 2ν in the denominator); use ν < 0.5")
    if nu < 0:
        raise FecheckError(f"Poisson's ratio must be ≥ 0, got {nu:g}")
    if nu > 0.49:
        warnings.warn(f"Poisson's ratio {nu:g} is within 0.01 of 0.5: the EF stiffness "
                      f"(∝ 1/(1 − 2ν)) is very large and ill-conditioned", stacklevel=2)
    if thickness_mm is not None:
        h = _check_number("cartilage thickness (contact.thickness_mm)", thickness_mm)
        if not h > 0:
            raise FecheckError(f"cartilage thickness must be > 0 mm, got {h:g}")


def ef_stiffness(youngs_MPa: float, poisson: float, thickness_mm: float) -> float:
    """EF stiffness per unit area k = (1−ν)E / ((1+ν)(1−2ν)h), N/mm³ (eq. 4.3)."""
    validate_material(youngs_MPa, poisson, thickness_mm)
    return (1 - poisson) * youngs_MPa / ((1 + poisson) * (1 - 2 * poisson) * thickness_mm)


def hertz_modulus(youngs_MPa: float, poisson: float, indenter_youngs_MPa: float = math.inf,
                  indenter_poisson: float = 0.3) -> float:
    """Effective modulus E* (MPa): 1/E* = (1−ν²)/E + (1−ν_i²)/E_i (E_i = inf: rigid)."""
    validate_material(youngs_MPa, poisson)
    inv = (1 - poisson ** 2) / youngs_MPa
    if not math.isinf(indenter_youngs_MPa):
        validate_material(indenter_youngs_MPa, indenter_poisson)
        inv += (1 - indenter_poisson ** 2) / indenter_youngs_MPa
    return 1.0 / inv


@dataclass(frozen=True, eq=False)
class LawResult:
    """A law's output for one contact (forces on the slave).

    surface : the contact the law read (a `PointContact` for `hertz_point`)
    pressure : (Q,) pressure at the quadrature points, MPa (none for a point contact)
    force : (3,) N;  moment : (3,) N·mm about `about`;  tangent : (6, 6) d[F, M]/dξ
    max_pressure : MPa at the deepest point;  max_depth : mm;  area : mm² (law's own
    contact area: the clipped area for foundation laws, πa² for Hertz)
    extra : law-specific values (Hertz: contact_radius_mm, p0_MPa, …)
    """

    surface: ContactSurface | PointContact
    pressure: np.ndarray
    force: np.ndarray
    moment: np.ndarray
    tangent: np.ndarray
    max_pressure: float
    area: float
    max_depth: float
    extra: dict = field(default_factory=dict)
    face_pressure_fn: Callable[[], np.ndarray] | None = None

    @property
    def mean_pressure(self) -> float:
        """|F| / area, MPa (0 without contact)."""
        return float(np.linalg.norm(self.force) / self.area) if self.area > 0 else 0.0

    def face_pressure(self) -> np.ndarray:
        """(n_slave_faces,) mean pressure on every slave face, MPa (0 off contact)."""
        return self.face_pressure_fn()


def _no_contact(surface: ContactSurface, about: np.ndarray) -> LawResult:
    z3 = np.zeros(3)
    n = surface.n_slave_faces
    return LawResult(surface, np.zeros(0), z3, z3.copy(), np.zeros((6, 6)), 0.0, 0.0, 0.0,
                     face_pressure_fn=lambda: np.zeros(n))


def foundation(surface: ContactSurface,
               pressure: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | float,
               about=(0.0, 0.0, 0.0)) -> LawResult:
    """Generic foundation law p = p(d) (p(0) = 0) integrated over the contact surface.

    `pressure(d)` returns (p, dp/dd) for depths d ≥ 0 (mm → MPa, MPa/mm), or is a number
    k (N/mm³) for the linear law p = k·d; depths ≤ 0 carry no pressure. `about` is the
    moment reference point, mm (world).
    """
    about = np.asarray(about, dtype=float)
    if surface.n_faces == 0:
        return _no_contact(surface, about)
    f = surface.qp_face
    w = surface.qp_weight
    if callable(pressure):
        d = np.maximum(surface.qp_depth, 0.0)
        values, slopes = (np.array(np.broadcast_to(v, d.shape), dtype=float)
                          for v in pressure(d))       # writable: one kernel signature
        stiffness = 0.0
    else:                                           # linear law p = k·d
        values = slopes = NO_VALUES
        stiffness = float(pressure)
    slide = surface.normal_slide
    p, force, moment, tangent, area = pressure_resultant(
        stiffness, values, slopes, surface.qp_depth, w, surface.qp_depth_twist,
        surface.qp_weight_twist, surface.qp_point, surface.normal, f,
        surface.normal_body == "slave", NO_SLIDE if slide is None else slide, about)
    max_depth = surface.max_depth
    if max_depth <= 0:
        p_max = 0.0
    elif callable(pressure):
        p_max = float(pressure(np.array([max_depth]))[0][0])
    else:
        p_max = pressure * max_depth

    def face_pressure() -> np.ndarray:
        out = np.zeros(surface.n_slave_faces)
        fa = np.bincount(f, w, minlength=surface.n_faces)
        fs = np.bincount(f, w * p, minlength=surface.n_faces)
        ok = fa > 0
        out[surface.face[ok]] = fs[ok] / fa[ok]
        return out

    return LawResult(surface, p, force, moment, tangent, p_max, area, max_depth,
                     face_pressure_fn=face_pressure)


def elastic_foundation(surface: ContactSurface, k_N_per_mm3: float, about=(0.0, 0.0, 0.0)
                       ) -> LawResult:
    """Linear EF law p = k·d (eq. 4.1-4.3); k in N/mm³ (see `ef_stiffness`)."""
    return foundation(surface, float(k_N_per_mm3), about)


def volumetric(surface: ContactSurface, k_v_N_per_mm3: float, about=(0.0, 0.0, 0.0)
               ) -> LawResult:
    """Volumetric law F = k_V·V (eq. 4.9, v_n = 0 in statics): p = k_V·d, k_V in N/mm³."""
    return foundation(surface, float(k_v_N_per_mm3), about)


def blankevoort_pressure(youngs_MPa: float, poisson: float, thickness_mm: float
                         ) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """p(d) = −k0·ln(1 − d/h), k0 = (1−ν)E/((1+ν)(1−2ν)) (MPa), linear beyond 0.9·h."""
    validate_material(youngs_MPa, poisson, thickness_mm)
    k0 = (1 - poisson) * youngs_MPa / ((1 + poisson) * (1 - 2 * poisson))
    h = float(thickness_mm)
    dc = BLANKEVOORT_LINEAR_FROM * h
    pc, sc = -k0 * math.log(1 - dc / h), k0 / (h - dc)

    def pressure(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        inner = np.minimum(d, dc)
        p = -k0 * np.log1p(-inner / h)
        s = k0 / (h - inner)
        beyond = d > dc
        return np.where(beyond, pc + sc * (d - dc), p), np.where(beyond, sc, s)

    return pressure


def blankevoort_foundation(surface: ContactSurface, youngs_MPa: float, poisson: float,
                           thickness_mm: float, about=(0.0, 0.0, 0.0)) -> LawResult:
    """Nonlinear EF of Blankevoort et al. 1991: p = −(1−ν)E/((1+ν)(1−2ν))·ln(1 − d/h)."""
    return foundation(surface, blankevoort_pressure(youngs_MPa, poisson, thickness_mm), about)


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
    Newton may stall; use `hertz_point` on a convex pair where there is one. `radius_mm` is the indenter radius R, `e_star_MPa` from `hertz_modulus`.
    Reports a = √(R d) (mm), p0 = 3P/(2πa²), mean pressure P/(πa²) and area πa².
    """
    about = np.asarray(about, dtype=float)
    if surface.n_faces == 0 or surface.max_depth <= 0:
        return _no_contact(surface, about)
    r = float(radius_mm)
    face, x, d, dd = _deepest_vertex(surface)
    n = surface.normal[face]
    load = 4.0 / 3.0 * e_star_MPa * math.sqrt(r) * d ** 1.5
    a = math.sqrt(r * d)
    p0 = 3 * load / (2 * math.pi * a * a)
    slide = surface.normal_slide
    _, force, moment, tangent, _ = pressure_resultant(
        0.0, np.array([load]), np.array([1.5 * load / d]), np.array([d]), np.ones(1),
        np.array([dd]), np.zeros((1, 6)), np.array([x]), np.array([n]),
        np.zeros(1, dtype=np.int64), surface.normal_body == "slave",
        NO_SLIDE if slide is None else slide[face:face + 1], about)
    centroids = surface.face_sum(surface.qp_point) / np.bincount(
        surface.qp_face, minlength=surface.n_faces)[:, None]

    def face_pressure() -> np.ndarray:
        rel = centroids - x
        rel -= np.outer(rel @ n, n)
        ratio = 1.0 - np.einsum("ij,ij->i", rel, rel) / (a * a)
        out = np.zeros(surface.n_slave_faces)
        out[surface.face] = p0 * np.sqrt(np.clip(ratio, 0.0, None))
        return out

    extra = {"contact_radius_mm": a, "p0_MPa": p0, "mean_pressure_MPa": load / (math.pi * a * a),
             "area_mm2": math.pi * a * a, "force_N": load}
    return LawResult(surface, np.zeros(len(surface.qp_depth)), force, moment, tangent, p0,
                     math.pi * a * a, d, extra, face_pressure_fn=face_pressure)


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
    load = 4.0 / 3.0 * e_star_MPa * math.sqrt(r) * d ** 1.5
    force = load * u
    arm = c - about
    moment = np.cross(arm, force)
    dforce = np.outer(u, 1.5 * load / d * contact.depth_twist) + load * contact.direction_twist
    tangent = np.vstack([dforce, np.cross(arm, dforce, axisa=0, axisb=0, axisc=0)])
    a = math.sqrt(r * d)
    area = math.pi * a * a
    p0 = 3 * load / (2 * area)

    def face_pressure() -> np.ndarray:
        rel = centroids() - c
        rel -= np.outer(rel @ u, u)
        ratio = 1.0 - np.einsum("ij,ij->i", rel, rel) / (a * a)
        return p0 * np.sqrt(np.clip(ratio, 0.0, None))

    extra = {"contact_radius_mm": a, "p0_MPa": p0, "mean_pressure_MPa": load / area,
             "area_mm2": area, "force_N": load, "depth_mm": d}
    return LawResult(contact, np.zeros(0), force, moment, tangent, p0, area, d, extra,
                     face_pressure_fn=no_mesh if centroids is None else face_pressure)
