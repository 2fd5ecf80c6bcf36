"""Axisymmetric (r, z) FE reference: a rigid sphere on a flat layer bonded to rigid bone.

Quadratic triangles (skfem ``ElementTriP2``) on a graded tensor-product mesh built by
skfem itself (``MeshTri.init_tensor``): uniform spacing ``size_mm`` under the contact
(out to 1.3 × the Hertz contact radius, an upper bound of the layer's contact radius),
then geometric growth (ratio 1.15) to the layer's rim; in z, spacing grows from
``size_mm`` at the top to at most h/6 at the bone. A tensor grid needs no Gmsh call, puts
nodes exactly on the axis and on the top, and grades separably, which is all a disc
needs. The layer's top is z = 0, its bottom z = -h (fixed), its rim free; the sphere
touches the top at the origin before loading. Contact: `fecheck.fe.contact.load_control`, node-wise
(the quadratic line facets have positive consistent loads 1/6, 2/3, 1/6), pressure
recovered by `fecheck.fe.pressure.recovery`.
"""

from __future__ import annotations

import time

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.contact.load_control import solve_contact
from fecheck.fe.material.elasticity import (
    FORMULATIONS,
    dilatation_matrix,
    lame,
    mean_dilatation_stiffness,
    resolve,
)
from fecheck.fe.pressure.recovery import contact_metrics, project_pressure
from fecheck.fe.pressure.results import FEContactResult
from fecheck.reference.closed_forms import hertz_sphere_on_plane


def _graded(fine_to: float, step: float, end: float, ratio: float, max_step: float) -> np.ndarray:
    """0, step, ..., fine_to, then steps growing by `ratio` (capped) up to `end`."""
    n = max(int(np.ceil(fine_to / step)), 1)
    xs = list(np.linspace(0.0, min(fine_to, end), n + 1))
    h = step
    while xs[-1] < end - 1e-12:
        h = min(h * ratio, max_step)
        xs.append(min(xs[-1] + h, end))
        if end - xs[-1] < 0.5 * h:
            xs[-1] = end
    return np.unique(np.asarray(xs))


def axisym_sphere_on_layer(load_N: float, radius_mm: float, E_MPa: float, nu: float,
                           thickness_mm: float, *, layer_radius_mm: float = 30.0,
                           size_mm: float = 0.05, gap: str = "reference",
                           solver: str = "cholmod",
                           formulation: str = "auto",
                           reach_mm: float | None = None) -> FEContactResult:
    """Rigid sphere (radius R) pressed with `load_N` on a bonded axisymmetric disc layer.

    Parameters
    ----------
    load_N : axial load, N
    radius_mm : sphere radius R, mm
    E_MPa, nu : Young's modulus (MPa) and Poisson's ratio of the layer
    thickness_mm : layer thickness h, mm
    layer_radius_mm : disc radius (free rim), mm
    size_mm : element size under the contact, mm
    gap : "reference" (vertical gap in the reference configuration) or "deformed"
        (vertical gap measured from the displaced node position)
    solver : sparse factorization, "cholmod" or "superlu"
    formulation : "displacement", "mixed" (an element-constant pressure condensed per
        element, `fecheck.fe.material.elasticity`) or "auto" (mixed for nearly incompressible ν)
    reach_mm : radius of the fine mesh and the contact candidates, mm (default 1.3 × the
        Hertz contact radius, an upper bound on a bonded layer; a thin layer's contact is
        far smaller)

    Returns
    -------
    FEContactResult; its ``points`` are (r, 0, 0) of the top nodes.
    """
    from skfem import Basis, ElementTriP2, ElementVector, MeshTri

    if formulation not in FORMULATIONS:
        raise FecheckError(f"formulation must be one of {', '.join(FORMULATIONS)}, "
                           f"got {formulation!r}")
    if gap not in ("reference", "deformed"):
        raise FecheckError(f"gap convention must be 'reference' or 'deformed', got {gap!r}")
    if not (0 < size_mm < thickness_mm):
        raise FecheckError(f"FE element size must be in (0, h={thickness_mm}) mm, got {size_mm}")
    hertz = hertz_sphere_on_plane(load_N, radius_mm, E_MPa, nu)
    a_max = np.sqrt(hertz.area_mm2 / np.pi) if reach_mm is None else reach_mm / 1.3
    if 1.3 * a_max >= layer_radius_mm:
        raise FecheckError(f"the contact (radius up to {a_max:.1f} mm) does not fit on a "
                           f"{layer_radius_mm} mm layer: enlarge the layer or lower the load")
    timing = {}
    t = time.perf_counter()
    r = _graded(1.3 * a_max, size_mm, layer_radius_mm, 1.15, 4 * thickness_mm)
    z = -_graded(0.0, size_mm, thickness_mm, 1.2, thickness_mm / 6)[::-1]
    mesh = MeshTri.init_tensor(r, z)
    basis = Basis(mesh, ElementVector(ElementTriP2()))
    K = axisym_stiffness(basis, E_MPa, nu, resolve(formulation, nu))
    timing["assemble"] = time.perf_counter() - t
    ir, iz = basis.split_indices()
    loc = basis.doflocs
    fixed = np.concatenate([ir[np.isclose(loc[0, ir], 0.0)],
                            ir[np.isclose(loc[1, ir], -thickness_mm)],
                            iz[np.isclose(loc[1, iz], -thickness_mm)]])
    free = np.setdiff1d(np.arange(basis.N), fixed)
    index = np.full(basis.N, -1)
    index[free] = np.arange(len(free))
    top = iz[np.isclose(loc[1, iz], 0.0)]
    top = top[np.argsort(loc[0, top])]
    top_r = ir[np.isclose(loc[1, ir], 0.0)]
    top_r = top_r[np.argsort(loc[0, top_r])]
    rt = loc[0, top]
    n_reach = int(np.sum(rt <= 1.3 * a_max)) | 1
    in_reach = np.arange(len(rt)) < n_reach
    cand, cand_r, rc = index[top[in_reach]], index[top_r[in_reach]], rt[in_reach]
    on_axis = cand_r < 0                 # u_r is fixed on the axis: no tangential shift there
    cand_r = np.maximum(cand_r, 0)
    R = radius_mm

    def gap0(shift: np.ndarray | None) -> np.ndarray:
        rr = rc if shift is None else rc + np.where(on_axis, 0.0, shift[:, 0])
        if np.any(rr >= R):
            raise FecheckError("contact candidates lie beyond the sphere's radius")
        return R - np.sqrt(R * R - rr * rr)

    sol = solve_contact(K[free][:, free], cand, gap0, load_N, hertz.depth_mm,
                        tangential=[cand_r], solver=solver, deformed_gap=(gap == "deformed"))
    timing.update(sol.timing_s)
    t = time.perf_counter()
    seg = np.stack([np.arange(0, len(rt) - 2, 2), np.arange(1, len(rt) - 1, 2),
                    np.arange(2, len(rt), 2)], axis=1)
    seg = seg[seg[:, 2] < n_reach]
    pressure = project_pressure(_line_p2_mass(rc, seg), sol.force_N)
    timing["recover"] = time.perf_counter() - t
    area = _node_area(rc, sol.active)
    metrics = contact_metrics(pressure, sol.force_N, area, sol.delta_mm)
    points = np.column_stack([rc, np.zeros_like(rc), np.zeros_like(rc)])
    return FEContactResult(metrics=metrics, points=points, pressure_MPa=pressure,
                           gap0_mm=gap0(None), nodal_force_N=sol.force_N, gap_mm=sol.gap_mm,
                           active=sol.active, faces=np.zeros((0, 3), dtype=np.int64),
                           n_dofs=len(free), n_elements=mesh.t.shape[1],
                           element="tri P2 (r, z)", size_under_contact_mm=float(size_mm),
                           iterations=sol.iterations, timing_s=timing,
                           max_penetration_mm=float(max(0.0, -sol.gap_mm.min())),
                           node_area_mm2=area)


def axisym_flat_punch(depth_mm: float, punch_radius_mm: float, E_MPa: float, nu: float,
                      thickness_mm: float, *, layer_radius_mm: float = 60.0,
                      size_mm: float = 0.05, formulation: str = "auto") -> float:
    """Force (N) of a rigid frictionless flat punch (radius a) pressed `depth_mm` into the
    bonded axisymmetric disc layer of `axisym_sphere_on_layer` (same mesh grading,
    `size_mm` out to a + h): u_z = −δ on the top nodes r ≤ a, u_r free; the force is the
    sum of their reactions. Linear: no contact iteration (the pressure under a flat punch
    on a bonded layer is compressive throughout)."""
    import scipy.sparse.linalg as sla
    from skfem import Basis, ElementTriP2, ElementVector, MeshTri

    if formulation not in FORMULATIONS:
        raise FecheckError(f"formulation must be one of {', '.join(FORMULATIONS)}, "
                           f"got {formulation!r}")
    a, h = punch_radius_mm, thickness_mm
    if not (0 < size_mm < h and 0 < a < layer_radius_mm - 2 * h):
        raise FecheckError(f"flat punch: element size must be in (0, h={h}) mm and the punch "
                           f"(a {a} mm) inside the {layer_radius_mm} mm layer less 2h")
    r = np.unique(np.concatenate([_graded(a, size_mm, a, 1.0, size_mm),
                                  a + _graded(h, size_mm, layer_radius_mm - a, 1.15, 4 * h)]))
    z = -_graded(0.0, size_mm, h, 1.2, h / 6)[::-1]
    basis = Basis(MeshTri.init_tensor(r, z), ElementVector(ElementTriP2()))
    K = axisym_stiffness(basis, E_MPa, nu, resolve(formulation, nu)).tocsr()
    ir, iz = basis.split_indices()
    loc = basis.doflocs
    punched = iz[np.isclose(loc[1, iz], 0.0) & (loc[0, iz] <= a * (1 + 1e-12))]
    fixed = np.concatenate([ir[np.isclose(loc[0, ir], 0.0)],
                            ir[np.isclose(loc[1, ir], -h)], iz[np.isclose(loc[1, iz], -h)],
                            punched])
    free = np.setdiff1d(np.arange(basis.N), fixed)
    u = np.zeros(basis.N)
    u[punched] = -depth_mm
    u[free] = sla.spsolve(K[free][:, free].tocsc(), -(K[free][:, punched] @ u[punched]))
    return float(-(K[punched] @ u).sum())


def axisym_stiffness(basis, E_MPa: float, nu: float, formulation: str = "displacement"):
    """Stiffness (N/mm, per radian times 2π: the whole ring) of axisymmetric isotropic
    elasticity on a scikit-fem (r, z) vector basis: strains ∂u_r/∂r, ∂u_z/∂z, u_r/r and
    the shear, weighted by 2πr; `formulation` 'mixed' puts the λ term on the element
    means of div u = ∂u_r/∂r + u_r/r + ∂u_z/∂z (`fecheck.fe.material.elasticity`)."""
    from skfem import BilinearForm, asm

    lam, mu = lame(E_MPa, nu)
    lam_point = 0.0 if formulation == "mixed" else lam

    @BilinearForm
    def axisym_elasticity(u, v, w):
        rr = w.x[0]

        def strains(f):
            return (f.grad[0][0], f.grad[1][1], f[0] / rr, 0.5 * (f.grad[0][1] + f.grad[1][0]))

        eu, ev = strains(u), strains(v)
        tr = eu[0] + eu[1] + eu[2]
        s = [2 * mu * eu[k] + lam_point * tr for k in range(3)] + [2 * mu * eu[3]]
        return 2 * np.pi * rr * (s[0] * ev[0] + s[1] * ev[1] + s[2] * ev[2] + 2 * s[3] * ev[3])

    K = asm(axisym_elasticity, basis)
    if formulation == "mixed":
        K = K + mean_dilatation_stiffness(*dilatation_matrix(
            basis, axisym_divergence, lambda x: 2 * np.pi * x[0]), lam)
    return K


def axisym_divergence(f, x: np.ndarray) -> np.ndarray:
    """div u = ∂u_r/∂r + u_r/r + ∂u_z/∂z of an (r, z) DiscreteField at points x."""
    return f.grad[0][0] + f.grad[1][1] + f[0] / x[0]


def _line_p2_mass(r: np.ndarray, seg: np.ndarray) -> np.ndarray:
    """Consistent mass ∫ φ_i φ_j 2πr dr of 3-node line elements (r0, r_mid, r1), mm²."""
    from numpy.polynomial.legendre import leggauss

    xi, wq = leggauss(4)
    s = 0.5 * (xi + 1.0)
    phi = np.stack([2 * (s - 0.5) * (s - 1), 4 * s * (1 - s), 2 * s * (s - 0.5)])
    M = np.zeros((len(r), len(r)))
    r0, r1 = r[seg[:, 0]], r[seg[:, 2]]
    length = r1 - r0
    rq = r0[:, None] + length[:, None] * s[None, :]
    w = 0.5 * wq[None, :] * length[:, None] * 2 * np.pi * rq
    local = np.einsum("iq,jq,eq->eij", phi, phi, w)
    np.add.at(M, (seg[:, :, None], seg[:, None, :]), local)
    return M


def _node_area(r: np.ndarray, active: np.ndarray) -> float:
    """π a² with a midway between the last node in contact and the first free one, mm².

    The error is at most half a spacing of contact radius (measured ±0.5% of the area at
    0.1 mm). Extrapolating p² from the last nodes was noisier: the recovered pressure
    oscillates over the last element.
    """
    if not active.any():
        return 0.0
    last = np.flatnonzero(active)[-1]
    a = r[last] if last + 1 >= len(r) else 0.5 * (r[last] + r[last + 1])
    return float(np.pi * a * a)
