"""Compiled (numba) accumulation of a contact law over the quadrature points of a surface.

`pressure_resultant` turns pressures at the points of a `ContactSurface` into the force,
moment and exact 6x6 tangent that `fecheck.laws` reports, in one pass (the NumPy form
took ~40 small array operations). Conventions as in `fecheck.laws`: forces on the slave
(N), moments about `about` (N·mm), tangent d[F, M]/dξ for the slave's twist ξ = (v, ω)
relative to the master; each point carries the force s_q·n_q, s_q = w_q·p_q, at x_q.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba import njit

from fecheck.errors import FecheckError


@njit(cache=True, fastmath=False, inline="always")
def close_resultant(tangent: np.ndarray, f0: float, f1: float, f2: float, m0: float,
                    m1: float, m2: float, xf: np.ndarray, slave_normals: bool,
                    about: np.ndarray):
    """The terms of `pressure_resultant` after its sums: the normals' turn (if
    `slave_normals`) and the points' motion added to `tangent` (6, 6) in place, from the
    force (f0, f1, f2) N, the moment (m0, m1, m2) N·mm about the origin and xf (3, 3)
    Σ x_q F_qᵀ; then the moment and tangent moved to `about` (3,) mm. Returns force (3,),
    moment (3,)."""
    trace = xf[0, 0] + xf[1, 1] + xf[2, 2]
    if slave_normals:
        # normals turning with the slave, ∂n_q/∂ω_k = e_k × n_q: Σ s_q e_k × n_q = e_k × F
        # and Σ s_q x_q × (e_k × n_q) = e_k (Σ s_q x_q·n_q) - Σ s_q n_q x_qk
        tangent[1, 3] -= f2
        tangent[2, 3] += f1
        tangent[0, 4] += f2
        tangent[2, 4] -= f0
        tangent[0, 5] -= f1
        tangent[1, 5] += f0
        for i in range(3):
            tangent[3 + i, 3 + i] += trace
            for k in range(3):
                tangent[3 + i, 3 + k] -= xf[k, i]
    # point motion: δx × F_q = −skew(F_q)(v − skew(x_q) ω)
    tangent[3, 1] += f2
    tangent[3, 2] -= f1
    tangent[4, 0] -= f2
    tangent[4, 2] += f0
    tangent[5, 0] += f1
    tangent[5, 1] -= f0
    for i in range(3):
        tangent[3 + i, 3 + i] -= trace
        for k in range(3):
            tangent[3 + i, 3 + k] += xf[i, k]
    force = np.array([f0, f1, f2])
    moment = np.array([m0, m1, m2])
    a0, a1, a2 = about[0], about[1], about[2]
    if a0 != 0.0 or a1 != 0.0 or a2 != 0.0:       # M_about = M − a × F
        moment[0] -= a1 * f2 - a2 * f1
        moment[1] -= a2 * f0 - a0 * f2
        moment[2] -= a0 * f1 - a1 * f0
        for k in range(6):
            t0, t1, t2 = tangent[0, k], tangent[1, k], tangent[2, k]
            tangent[3, k] -= a1 * t2 - a2 * t1
            tangent[4, k] -= a2 * t0 - a0 * t2
            tangent[5, k] -= a0 * t1 - a1 * t0
    return force, moment


# One fused compiled loop over the faces for speed: its branches are the cases of one
# evaluation, kept together on purpose (hence above the complexity ceiling).
@njit(cache=True, fastmath=False)
def pressure_resultant(stiffness: float, pressure: np.ndarray, slope: np.ndarray,  # noqa: C901
                       depth: np.ndarray, weight: np.ndarray, depth_twist: np.ndarray,
                       weight_twist: np.ndarray, point: np.ndarray, normal: np.ndarray,
                       face: np.ndarray, slave_normals: bool, normal_slide: np.ndarray,
                       qp_clip: np.ndarray, clip_share: np.ndarray, clip_face: np.ndarray,
                       clip_edge: np.ndarray, clip_rate: np.ndarray, about: np.ndarray):
    """Wrench and tangent of the pressures at Q points; points with depth ≤ 0 carry none.

    Parameters
    ----------
    stiffness : k (N/mm³) of the linear law p = k·d, used when `pressure` is empty
    pressure, slope : (Q,) p (MPa) and dp/dd (MPa/mm) at the points, or empty (0,)
    depth, weight, depth_twist, weight_twist, point, face : the quadrature of a
        `ContactSurface`: (Q,) mm, (Q,) mm², (Q, 6), (Q, 6), (Q, 3) mm, (Q,)
    normal : (m, 3) unit normal of each face (direction of the pressure on the slave)
    slave_normals : the normals turn with the slave (∂n/∂ω = -[n]×)
    normal_slide : (m, 3, 6) extra ∂n/∂ξ of sliding master normals, or empty (0, 3, 6)
    qp_clip, clip_share, clip_face, clip_edge, clip_rate : the slide of the points on
        faces cut by the clip line (`fecheck.contact.surface.ContactSurface`), or empty
    about : (3,) moment reference point, mm

    Returns
    -------
    pressure (Q,) MPa, force (3,) N, moment (3,) N·mm, tangent (6, 6), area (mm², the
    weight of the points with positive depth)
    """
    n_q = depth.shape[0]
    linear = pressure.size == 0
    sliding = normal_slide.shape[0] > 0
    p_out = np.zeros(n_q)
    arm = np.zeros((n_q, 6))                      # unit wrenches [n, x × n]
    gq = np.zeros((n_q, 6))                       # d(w·p)/dξ
    nt = np.zeros((3, 6))
    tangent = np.zeros((6, 6))
    f0 = f1 = f2 = m0 = m1 = m2 = area = 0.0
    xf00 = xf01 = xf02 = xf10 = xf11 = xf12 = xf20 = xf21 = xf22 = 0.0   # Σ x_q F_qᵀ
    for q in range(n_q):
        if depth[q] <= 0.0:
            continue
        w = weight[q]
        if linear:
            p = stiffness * depth[q]
            dpw = stiffness * w
        else:
            p = pressure[q]
            dpw = slope[q] * w
        p_out[q] = p
        s = w * p
        area += w
        for k in range(6):
            gq[q, k] = dpw * depth_twist[q, k] + p * weight_twist[q, k]
        f = face[q]
        n0, n1, n2 = normal[f, 0], normal[f, 1], normal[f, 2]
        x0, x1, x2 = point[q, 0], point[q, 1], point[q, 2]
        a3, a4, a5 = x1 * n2 - x2 * n1, x2 * n0 - x0 * n2, x0 * n1 - x1 * n0
        arm[q, 0], arm[q, 1], arm[q, 2], arm[q, 3], arm[q, 4], arm[q, 5] = n0, n1, n2, a3, a4, a5
        f0 += s * n0
        f1 += s * n1
        f2 += s * n2
        m0 += s * a3
        m1 += s * a4
        m2 += s * a5
        xf00 += x0 * n0 * s
        xf01 += x0 * n1 * s
        xf02 += x0 * n2 * s
        xf10 += x1 * n0 * s
        xf11 += x1 * n1 * s
        xf12 += x1 * n2 * s
        xf20 += x2 * n0 * s
        xf21 += x2 * n1 * s
        xf22 += x2 * n2 * s
        if sliding:                               # sliding master normals
            nt[:, :] = normal_slide[f]
            for k in range(6):
                c0, c1, c2 = nt[0, k], nt[1, k], nt[2, k]
                tangent[0, k] += s * c0
                tangent[1, k] += s * c1
                tangent[2, k] += s * c2
                tangent[3, k] += s * (x1 * c2 - x2 * c1)
                tangent[4, k] += s * (x2 * c0 - x0 * c2)
                tangent[5, k] += s * (x0 * c1 - x1 * c0)
    tangent += np.dot(arm.T, gq)                  # Σ arm_q gq_qᵀ
    # points sliding with a clip line: Σ_q s_q δx_q × n = Σ_c,e σ_ce (edge_ce × n) rate_ceᵀ
    sigma = np.zeros((clip_face.shape[0], 2))
    for q in range(qp_clip.shape[0]):
        c = qp_clip[q]
        if c >= 0:
            s = weight[q] * p_out[q]
            sigma[c, 0] += s * clip_share[q, 0]
            sigma[c, 1] += s * clip_share[q, 1]
    for c in range(clip_face.shape[0]):
        f = clip_face[c]
        n0, n1, n2 = normal[f, 0], normal[f, 1], normal[f, 2]
        for e in range(2):
            g0, g1, g2 = clip_edge[c, e, 0], clip_edge[c, e, 1], clip_edge[c, e, 2]
            t0 = sigma[c, e] * (g1 * n2 - g2 * n1)
            t1 = sigma[c, e] * (g2 * n0 - g0 * n2)
            t2 = sigma[c, e] * (g0 * n1 - g1 * n0)
            for k in range(6):
                tangent[3, k] += t0 * clip_rate[c, e, k]
                tangent[4, k] += t1 * clip_rate[c, e, k]
                tangent[5, k] += t2 * clip_rate[c, e, k]
    xf = np.array([[xf00, xf01, xf02], [xf10, xf11, xf12], [xf20, xf21, xf22]])
    force, moment = close_resultant(tangent, f0, f1, f2, m0, m1, m2, xf, slave_normals,
                                    about)
    return p_out, force, moment, tangent, area


LINEAR, BLANKEVOORT, CALIBRATED, POWER = 0, 1, 2, 3
"""Codes of the compiled pressure laws p(d) (`law_values`), each with a parameter vector."""


@dataclass(frozen=True)
class Kernel:
    """One compiled pressure law of `law_values`: its formula and parameter names."""

    name: str
    formula: str
    params: tuple[str, ...]


KERNELS: dict[int, Kernel] = {
    LINEAR: Kernel("linear", "p = k·d", ("k",)),
    BLANKEVOORT: Kernel("blankevoort", "p = −k0·ln(1 − d/h), linear beyond d_c",
                        ("k0", "h", "d_c", "p_c", "s_c")),
    CALIBRATED: Kernel("calibrated", "p = C·d·(d + d_s)^(n − 1)", ("C", "n", "d_s")),
    POWER: Kernel("power", "p = c·d^m, m ≥ 1", ("c", "m")),
}
"""Every compiled kernel by code: `law_values` computes these and refuses any other code."""


def check_kernel(kind: int, params: np.ndarray) -> None:
    """`FecheckError` unless `kind` is a code of `KERNELS` and `params` holds its
    parameters."""
    kernel = KERNELS.get(kind)
    if kernel is None:
        raise FecheckError(f"unknown compiled law kernel {kind!r}; the kernels are "
                           + ", ".join(f"{k} = {v.name}" for k, v in KERNELS.items()))
    if len(params) != len(kernel.params):
        raise FecheckError(f"the {kernel.name} law kernel ({kernel.formula}) takes "
                           f"{', '.join(kernel.params)}, got {len(params)} parameters")


@njit(cache=True, fastmath=False)
def law_values(kind: int, params: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """p(d) (MPa) and dp/dd (MPa/mm) at depths d (n,) ≥ 0 (mm) of a compiled law
    (`KERNELS`; any other code raises ValueError):

    * LINEAR, (k,): p = k·d (N/mm³);
    * BLANKEVOORT, (k0, h, d_c, p_c, s_c): p = −k0·ln(1 − d/h), continued linearly
      (p_c + s_c·(d − d_c)) beyond d_c (`fecheck.laws.foundation.blankevoort_pressure`);
    * CALIBRATED, (C, n, d_s): p = C·d·(d + d_s)^(n − 1) (`fecheck.laws.calibrated`);
    * POWER, (c, m): p = c·d^m, m ≥ 1 (a generic foundation, `fecheck.laws.registry`).
    """
    p = np.empty(d.size)
    slope = np.empty(d.size)
    for i in range(d.size):
        x = d[i]
        if kind == LINEAR:
            p[i], slope[i] = params[0] * x, params[0]
        elif kind == BLANKEVOORT:
            k0, h, dc = params[0], params[1], params[2]
            if x > dc:
                p[i], slope[i] = params[3] + params[4] * (x - dc), params[4]
            else:
                p[i], slope[i] = -k0 * np.log1p(-x / h), k0 / (h - x)
        elif kind == CALIBRATED:
            C, n, ds = params[0], params[1], params[2]
            s = x + ds
            power = s ** (n - 1.0)
            p[i], slope[i] = C * x * power, C * power * (n * x + ds) / s
        elif kind == POWER:
            c, m = params[0], params[1]
            power = x ** (m - 1.0)
            p[i], slope[i] = c * x * power, c * m * power
        else:
            raise ValueError("law_values: unknown compiled law kernel code")
    return p, slope


def law_function(kind: int, params: np.ndarray
                 ) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """`law_values` of one law as a function of depths of any shape (mm → MPa, MPa/mm)."""
    params = np.asarray(params, dtype=float)
    check_kernel(kind, params)

    def pressure(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = np.asarray(d, dtype=float)
        p, slope = law_values(kind, params, np.ascontiguousarray(x.ravel()))
        return p.reshape(x.shape), slope.reshape(x.shape)

    return pressure


NO_VALUES = np.zeros(0)
NO_SLIDE = np.zeros((0, 3, 6))
NO_ROWS = np.zeros(0, dtype=np.int64)
NO_CLIP = (NO_ROWS, np.zeros((0, 2)), NO_ROWS, np.zeros((0, 2, 3)), np.zeros((0, 2, 6)))
"""Empty `qp_clip, clip_share, clip_face, clip_edge, clip_rate`: no cut faces."""


def warm_up() -> None:
    """Compile `pressure_resultant`, or load it from numba's on-disk cache (~1 s in a
    fresh process), so that the first contact evaluation does not pay for it."""
    pressure_resultant(0.0, NO_VALUES, NO_VALUES, NO_VALUES, NO_VALUES, np.zeros((0, 6)),
                       np.zeros((0, 6)), np.zeros((0, 3)), np.zeros((0, 3)),
                       NO_ROWS, False, NO_SLIDE, *NO_CLIP, np.zeros(3))
