"""Foundation laws: a `ContactSurface` → pressure, resultant wrench and its exact tangent.

Every law returns a `LawResult`: the pressure at each quadrature point (MPa), the force
F (N) and moment M (N·mm, about a given point) that the master exerts on the SLAVE, and
the tangent d[F, M]/dξ (6, 6) with respect to the twist ξ = (v, ω) of the slave relative
to the master (see `fecheck.contact.surface`). The tangent is exact for the discrete
model: chain rule through ``qp_depth_twist``, ``qp_weight_twist``, the motion of the
points ``δx = v + ω × x`` and the motion of the normals ``normal_twist``.

Laws (thesis chapter 4), each a small function of the surface and the material:

* `elastic_foundation` (eq. 4.1-4.3): p = k·d, k = (1−ν)E / ((1+ν)(1−2ν)h) (N/mm³).
* `volumetric` (eq. 4.9): F = k_V·V (1 + a·v_n) with v_n = 0 in statics, i.e. p = k_V·d.
  The thesis's k_V ≈ 1e7 N/m³ is 1e-2 N/mm³ (1 m³ = 1e9 mm³), about 450 times softer
  than the baseline EF foundation (4.487 N/mm³).
* `blankevoort_foundation`: the nonlinear foundation of Blankevoort et al. 1991
  (J. Biomech. 24(11):1019-1031, eq. for the cartilage layer),
  p = −(1−ν)E/((1+ν)(1−2ν)) · ln(1 − d/h). It stiffens without bound as d → h; beyond
  d = 0.9·h it is continued linearly (C¹) so that a Newton iterate that overshoots stays
  finite (the equilibrium itself is reported with its depth; d > 0.9 h is flagged).
* Hertz: `fecheck.laws.hertz`.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from fecheck.contact.surface import ContactSurface
from fecheck.laws.kernel import (
    BLANKEVOORT,
    NO_SLIDE,
    NO_VALUES,
    law_function,
    pressure_resultant,
)
from fecheck.laws.materials import validate_material
from fecheck.laws.result import LawResult, no_contact

BLANKEVOORT_LINEAR_FROM = 0.9      # fraction of h beyond which the log law is continued linearly


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
        return no_contact(surface, about)
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
        surface.normal_body == "slave", NO_SLIDE if slide is None else slide,
        surface.qp_clip, surface.clip_share, surface.clip_face, surface.clip_edge,
        surface.clip_rate, about)
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


def blankevoort_params(youngs_MPa: float, poisson: float, thickness_mm: float) -> np.ndarray:
    """(k0, h, d_c, p_c, s_c) of the log law (`fecheck.laws.kernel.law_values`):
    k0 = (1−ν)E/((1+ν)(1−2ν)) MPa, h mm, linear from d_c = 0.9·h with p_c, s_c."""
    validate_material(youngs_MPa, poisson, thickness_mm)
    k0 = (1 - poisson) * youngs_MPa / ((1 + poisson) * (1 - 2 * poisson))
    h = float(thickness_mm)
    dc = BLANKEVOORT_LINEAR_FROM * h
    return np.array([k0, h, dc, -k0 * math.log(1 - dc / h), k0 / (h - dc)])


def blankevoort_pressure(youngs_MPa: float, poisson: float, thickness_mm: float
                         ) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """p(d) = −k0·ln(1 − d/h), k0 = (1−ν)E/((1+ν)(1−2ν)) (MPa), linear beyond 0.9·h."""
    return law_function(BLANKEVOORT, blankevoort_params(youngs_MPa, poisson, thickness_mm))


def blankevoort_foundation(surface: ContactSurface, youngs_MPa: float, poisson: float,
                           thickness_mm: float, about=(0.0, 0.0, 0.0)) -> LawResult:
    """Nonlinear EF of Blankevoort et al. 1991: p = −(1−ν)E/((1+ν)(1−2ν))·ln(1 − d/h)."""
    return foundation(surface, blankevoort_pressure(youngs_MPa, poisson, thickness_mm), about)

