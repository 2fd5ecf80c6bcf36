"""Transversely isotropic linear elasticity: one stiff fibre direction d per element.

The material has a plane of isotropy (modulus E_p, Poisson's ratio ν_p, shear modulus
G_p = E_p / (2 (1 + ν_p))) normal to the fibre direction d (modulus E_t; ν_tp: the strain
across the fibres under a stress along them is -ν_tp σ/E_t; G_t: shear in planes that
contain d). With d along the third axis its compliance (Voigt, engineering shears, order
xx yy zz yz xz xy) is

    S = [[1/E_p, -ν_p/E_p, -ν_tp/E_t], [., 1/E_p, -ν_tp/E_t], [., ., 1/E_t]] ⊕
        diag(1/G_t, 1/G_t, 1/G_p),

and C = S⁻¹. For any d the stiffness tensor is written without a rotation matrix
(Spencer's invariant form, m = d ⊗ d):

    C_abcd = λ δ_ab δ_cd + μ_p (δ_ac δ_bd + δ_ad δ_bc) + α (δ_ab m_cd + m_ab δ_cd)
             + (G_t − μ_p)(m_ac δ_bd + m_ad δ_bc + δ_ac m_bd + δ_ad m_bc) + β m_ab m_cd,

with λ = C12, μ_p = G_p, α = C13 − C12, β = C33 − C11 − 2α − 4(G_t − μ_p) read off the
fibre-along-z matrix, so it rotates with d exactly. The 3D P2 stiffness is assembled on
quadratic tetrahedra with one direction per element or per quadrature point; the
axisymmetric (r, z) one with fibres along the hoop θ, where (r, z, θ) is the
fibre-along-third-axis frame itself.

Meniscus values (`MENISCUS`) are literature values, not checked against Donahue et al.
2002 (J Biomech Eng 124:273-280) or Haut Donahue et al. 2003 (J Biomech 36:19-34), whose
texts could not be opened: a citing study of knee models ("Sensitivity of the
tibio-femoral response ...", as excerpted by scite.ai) quotes for the menisci modulus and
Poisson's ratio 20 MPa and 0.2 in the radial and axial directions and 140 MPa and 0.3 in
the circumferential one. Read here as E_p = E_r = E_z 20 MPa, ν_p = ν_rz 0.2, E_t = E_θ
140 MPa, ν_tp = ν_θr = ν_θz 0.3. It gives no fibre shear modulus: `MENISCUS` assumes
G_t = G_p = E_p / (2 (1 + ν_p)) until the source's value is checked.
Units: N, mm, MPa.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from fecheck.errors import FecheckError


@dataclass(frozen=True)
class TransIso:
    """Transversely isotropic constants: E_p, E_t, G_t in MPa; ν_p, ν_tp dimensionless
    (p: the plane of isotropy, across the fibres; t: along the fibres)."""

    E_p: float
    E_t: float
    nu_p: float
    nu_tp: float
    G_t: float

    @property
    def G_p(self) -> float:
        """Shear modulus in the plane of isotropy, E_p / (2 (1 + ν_p)), MPa."""
        return self.E_p / (2.0 * (1.0 + self.nu_p))

    def __str__(self) -> str:
        return (f"E_p {self.E_p} MPa, E_t {self.E_t} MPa, nu_p {self.nu_p}, "
                f"nu_tp {self.nu_tp}, G_t {self.G_t} MPa")


MENISCUS = TransIso(E_p=20.0, E_t=140.0, nu_p=0.2, nu_tp=0.3, G_t=20.0 / (2 * 1.2))
"""Meniscus, fibres circumferential (see the module's note on the sources and G_t)."""


def local_compliance(m: TransIso) -> np.ndarray:
    """(6, 6) Voigt compliance (1/MPa, engineering shears) with the fibres along z."""
    S = np.zeros((6, 6))
    S[:2, :2] = np.array([[1.0, -m.nu_p], [-m.nu_p, 1.0]]) / m.E_p
    S[:2, 2] = S[2, :2] = -m.nu_tp / m.E_t
    S[2, 2] = 1.0 / m.E_t
    S[3, 3] = S[4, 4] = 1.0 / m.G_t
    S[5, 5] = 1.0 / m.G_p
    return S


def local_stiffness(m: TransIso) -> np.ndarray:
    """(6, 6) Voigt stiffness (MPa) with the fibres along z; `FecheckError` unless the
    constants are finite, positive and give a positive definite compliance."""
    values = np.array([m.E_p, m.E_t, m.nu_p, m.nu_tp, m.G_t], dtype=float)
    if not np.all(np.isfinite(values)) or min(m.E_p, m.E_t, m.G_t) <= 0:
        raise FecheckError(f"transversely isotropic material: moduli must be positive "
                           f"numbers, got {m}")
    S = local_compliance(m)
    if np.linalg.eigvalsh(S).min() <= 0:
        raise FecheckError(f"transversely isotropic material is not positive definite "
                           f"({m}): need |nu_p| < 1 and nu_tp^2 < E_t (1 - nu_p) / (2 E_p)")
    return np.linalg.inv(S)


def stiffness_tensor(m: TransIso, directions: np.ndarray) -> np.ndarray:
    """(n, 3, 3, 3, 3) stiffness tensors C_abcd (MPa) for fibre `directions` (n, 3),
    normalised here; `FecheckError` on a zero or non-finite direction."""
    d = np.asarray(directions, dtype=float).reshape(-1, 3)
    norm = np.linalg.norm(d, axis=1)
    if not np.all(np.isfinite(norm)) or np.any(norm <= 0):
        bad = int(np.flatnonzero(~(np.isfinite(norm) & (norm > 0)))[0])
        raise FecheckError(f"fibre direction {bad} is zero or not finite: give a unit "
                           f"vector per element")
    d = d / norm[:, None]
    C6 = local_stiffness(m)
    lam, mu = C6[0, 1], m.G_p
    alpha = C6[0, 2] - C6[0, 1]
    shear = C6[3, 3] - mu
    beta = C6[2, 2] - C6[0, 0] - 2 * alpha - 4 * shear
    eye = np.eye(3)
    M = np.einsum("na,nb->nab", d, d)
    C = (lam * np.einsum("ab,cd->abcd", eye, eye)
         + mu * (np.einsum("ac,bd->abcd", eye, eye) + np.einsum("ad,bc->abcd", eye, eye)))
    C = np.broadcast_to(C, (len(d), 3, 3, 3, 3)).copy()
    C += alpha * (np.einsum("ab,ncd->nabcd", eye, M) + np.einsum("nab,cd->nabcd", M, eye))
    C += shear * (np.einsum("nac,bd->nabcd", M, eye) + np.einsum("nad,bc->nabcd", M, eye)
                  + np.einsum("ac,nbd->nabcd", eye, M) + np.einsum("ad,nbc->nabcd", eye, M))
    C += beta * np.einsum("nab,ncd->nabcd", M, M)
    return C


VOIGT = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))


def voigt_stiffness(m: TransIso, directions: np.ndarray) -> np.ndarray:
    """(n, 6, 6) Voigt stiffness (MPa; order xx yy zz yz xz xy, engineering shears) for
    fibre `directions` (n, 3)."""
    C = stiffness_tensor(m, directions)
    i, j = np.array(VOIGT).T
    return C[:, i[:, None], j[:, None], i[None, :], j[None, :]]


def hoop_directions(centres: np.ndarray, axis_point: np.ndarray,
                    axis: np.ndarray) -> np.ndarray:
    """(n, 3) unit circumferential directions axis × (x − axis_point) at `centres` (n, 3),
    mm: fibres around the `axis` (e.g. a meniscus's arc); `FecheckError` for a centre on
    the axis."""
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    t = np.cross(a, np.asarray(centres, dtype=float) - np.asarray(axis_point, dtype=float))
    norm = np.linalg.norm(t, axis=1)
    if np.any(norm <= 1e-12 * max(1.0, float(norm.max(initial=0.0)))):
        k = int(np.argmin(norm))
        raise FecheckError(f"element centre {np.round(centres[k], 3).tolist()} mm lies on the "
                           f"fibre axis: the hoop direction is undefined there")
    return t / norm[:, None]


def p2_transiso(mesh, m: TransIso, directions: np.ndarray | Callable, chunk: int = 8192):
    """(basis, K): transversely isotropic small-strain stiffness (N/mm) on the quadratic
    tetrahedra of the scikit-fem `mesh`. `directions`: one fibre direction per element
    (nel, 3), or a function of points (n, 3) mm giving their directions (n, 3), evaluated
    at every quadrature point (a curved fibre field: on the hoop-stiff ring of
    tests/fe/test_fe_anisotropy.py the per-element field's nodal error is 1.8 / 0.9 / 0.46 %
    at 7.5 / 3.75 / 1.9° elements, the per-point field's 0.57 / 0.17 / 0.08 %).
    K_(ia)(jb) = Σ_T ∫ ∂_c φ_i C_acbd ∂_d φ_j, formed from the scalar P2 gradients in
    chunks of `chunk` elements (node-major local dof order, as scikit-fem numbers the
    vector basis); degree-2 quadrature is exact for affine P2 and constant C."""
    from skfem import Basis, ElementTetP2, ElementVector

    nel = mesh.t.shape[1]
    basis = Basis(mesh, ElementVector(ElementTetP2()), intorder=2)
    scalar = Basis(mesh, ElementTetP2(), intorder=2)
    if callable(directions):
        x = np.asarray(scalar.global_coordinates())                     # (3, nel, nq)
        directions = np.asarray(directions(x.reshape(3, -1).T), dtype=float).reshape(
            nel, x.shape[2], 3)
    directions = np.asarray(directions, dtype=float)
    if directions.shape[0] != nel or directions.shape[-1] != 3 or directions.ndim > 3:
        raise FecheckError(f"need one fibre direction per element ({nel}, 3), "
                           f"got shape {directions.shape}")
    grads = np.array([phi[0].grad for phi in scalar.basis])             # (10, 3, nel, nq)
    K = sp.csr_matrix((basis.N, basis.N))
    for start in range(0, nel, chunk):
        part = slice(start, start + chunk)
        g, dx = grads[:, :, part], scalar.dx[part]
        C = stiffness_tensor(m, directions[part])
        if directions.ndim == 2:
            a = np.einsum("iceq,jdeq,eq->eijcd", g, g, dx, optimize=True)
            ke = np.einsum("eijcd,eacbd->eiajb", a, C, optimize=True)
        else:
            C = C.reshape(dx.shape + (3, 3, 3, 3))
            ke = np.einsum("iceq,jdeq,eq,eqacbd->eiajb", g, g, dx, C, optimize=True)
        ke = ke.reshape(-1, 30, 30)
        dofs = basis.element_dofs[:, part].T.astype(np.int32)            # (e, 30)
        K = K + sp.csr_matrix((ke.ravel(), (np.repeat(dofs, 30, axis=1).ravel(),
                                            np.tile(dofs, (1, 30)).ravel())),
                              shape=(basis.N, basis.N))
    return basis, K


def axisym_hoop_stiffness(basis, m: TransIso):
    """Stiffness (N/mm, the whole ring: weight 2πr) of axisymmetric elasticity with the
    fibres along the hoop θ on a scikit-fem (r, z) vector basis: strains ∂u_r/∂r,
    ∂u_z/∂z, u_r/r and γ_rz; (r, z) is the plane of isotropy, so the stress is the
    fibre-along-third-axis `local_stiffness` on (ε_rr, ε_zz, ε_θθ) and G_p γ_rz."""
    from skfem import BilinearForm, asm

    C = local_stiffness(m)[:3, :3]
    G_p = m.G_p

    @BilinearForm
    def hoop_elasticity(u, v, w):
        rr = w.x[0]

        def strains(f):
            return (f.grad[0][0], f.grad[1][1], f[0] / rr, f.grad[0][1] + f.grad[1][0])

        eu, ev = strains(u), strains(v)
        normal = sum(C[k, j] * eu[j] * ev[k] for k in range(3) for j in range(3))
        return 2 * np.pi * rr * (normal + G_p * eu[3] * ev[3])

    return asm(hoop_elasticity, basis)
